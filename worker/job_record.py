"""A job's public record, as plain JSON-ready data: the body of ``GET /v1/jobs/{id}``
(``conformorph.service.schemas.JobPublic`` validates it) and of the job's webhook POST.

Built here, on the worker side, because the webhook is sent by a worker, which
never imports the service; the API turns the same dict into its response model.
"""

from __future__ import annotations

import json
from typing import Any

from conformorph.worker.job_store.callbacks import CallbackView
from conformorph.worker.job_store.views import JobView


def _stage_state(job: JobView, stage: str) -> str:
    if stage in job.stages_done:
        return "done"
    if job.stage == stage:
        if job.state == "running":
            return "running"
        if job.state in ("failed", "cancelled"):
            return job.state
    return "pending"


def public_params(params: dict[str, Any]) -> dict[str, Any]:
    """Job parameters without internal storage keys (an uploaded file becomes its id)."""
    out: dict[str, Any] = {}
    for k, v in params.items():
        if isinstance(v, dict) and "storage_key" in v:
            out[k] = v.get("id")
        elif (
            isinstance(v, list) and v and all(isinstance(x, dict) and "storage_key" in x for x in v)
        ):
            out[k] = [x.get("id") for x in v]
        else:
            out[k] = v
    return out


#: a job parameter whose JSON is larger than this (bytes) is shown by reference in the job
#: record: a 100k-entry anchor ``paths`` list made every GET of its job about 200 KB
PARAM_INLINE_BYTES = 4096


def _json_size(value: Any, limit: int) -> int:
    """The compact JSON size of ``value``, counted only as far as ``limit`` + 1 bytes
    for long lists (the common large parameter): linear, and cheap on small values."""
    if isinstance(value, list) and len(value) > limit:
        return limit + 1  # every entry takes at least one byte and a comma
    return len(json.dumps(value, separators=(",", ":")))


def params_by_reference(params: dict[str, Any], base: str) -> dict[str, Any]:
    """``params`` with each value over :data:`PARAM_INLINE_BYTES` replaced by a reference.

    Parameters
    ----------
    params : dict
        Public job parameters (:func:`public_params`).
    base : str
        The job's URL path, ``/v1/jobs/{id}``.

    Returns
    -------
    dict
        The same keys; a large value becomes ``{"ref": "<base>/params#/<key>",
        "entries": <its length>}`` (``GET <base>/params`` returns every value whole).
    """
    out: dict[str, Any] = {}
    for k, v in params.items():
        if isinstance(v, list | dict) and _json_size(v, PARAM_INLINE_BYTES) > PARAM_INLINE_BYTES:
            out[k] = {"ref": f"{base}/params#/{k}", "entries": len(v)}
        else:
            out[k] = v
    return out


def callback_record(cb: CallbackView) -> dict[str, Any]:
    """The public part of a job's webhook: URL, status, attempts (never the secret)."""
    return {
        "url": cb.url,
        "signed": cb.secret is not None,
        "status": cb.status,
        "attempts": [dict(a) for a in cb.attempts],
    }


def job_record(job: JobView, callback: CallbackView | None = None) -> dict[str, Any]:
    """The public record of ``job`` (with its webhook's public part when given)."""
    base = f"/v1/jobs/{job.id}"
    return {
        "id": job.id,
        "kind": job.kind,
        "state": job.state,
        "stage": job.stage,
        "progress": round(job.progress, 4),
        "stages": [
            {"name": s, "state": _stage_state(job, s), "seconds": job.stage_seconds.get(s)}
            for s in job.stages
        ],
        "created_at": job.created_at,
        "started_at": job.started_at,
        "finished_at": job.finished_at,
        "error": dict(job.error) if job.error else None,
        "artifacts": [
            {
                "name": name,
                "url": f"{base}/artifacts/{name}",
                "content_type": str(rec["content_type"]),
                "size": int(rec["size"]),
                "etag": str(rec["etag"]),
            }
            for name, rec in sorted(job.artifacts.items())
            if not rec.get("internal")
        ],
        "params": params_by_reference(public_params(job.params), base),
        "callback": callback_record(callback) if callback is not None else None,
        "links": {"self": base, "events": f"{base}/events"},
    }
