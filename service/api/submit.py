"""Creating a job: limits, idempotency, enqueueing; the 202 answer with ``Location``.

A job route takes ``job: SubmissionDep`` (the caller, settings, store, task
client, response and ``Idempotency-Key`` header together), checks and builds its
parameters, and ends with ``return await job.submit(kind, params)``; it is
declared with ``responses=JOB_RESPONSES``.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Annotated, Any

from fastapi import Depends, Header, Response
from fastapi.concurrency import run_in_threadpool

from conformorph.service.api.deps import OwnerDep, SettingsDep, StoreDep, TaskClientDep
from conformorph.service.api.view import job_callback, job_public
from conformorph.service.core.config import Settings
from conformorph.service.errors import ApiError
from conformorph.service.schemas import CallbackFields, ErrorBody, JobPublic
from conformorph.service.task_client import AsyncTasks
from conformorph.worker.callbacks import CallbackPolicy, CallbackRefused, check_destination
from conformorph.worker.job_store import InputGone, JobStore, MeshView, TooManyActiveJobs
from conformorph.worker.secret_box import box_for

SUBMIT_ERRORS: dict[int | str, dict[str, object]] = {
    401: {"model": ErrorBody, "description": "missing or unknown API key"},
    404: {
        "model": ErrorBody,
        "description": "an input id is unknown for this key (input_expired: deleted by the "
        "retention cleanup)",
    },
    409: {"model": ErrorBody, "description": "Idempotency-Key reused for a different request"},
    422: {
        "model": ErrorBody,
        "description": "invalid parameters, over a limit, or a callback_url whose destination "
        "is not allowed (callback_not_allowed)",
    },
    429: {"model": ErrorBody, "description": "too many queued or running jobs for this key"},
    503: {"model": ErrorBody, "description": "the broker refused the job (retry later)"},
}

#: the responses of every job-creating route: 202 (new job), 200 (same Idempotency-Key), errors
JOB_RESPONSES: dict[int | str, dict[str, object]] = {
    200: {"model": JobPublic, "description": "same Idempotency-Key: the existing job"},
    **SUBMIT_ERRORS,
}


_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def missing_input(store: JobStore, owner: str, item_id: str, what: str, field: str) -> ApiError:
    """The 404 for an input id a job names but that is not stored: ``input_expired`` when
    the retention cleanup deleted it (as the README promises), else ``not_found``."""
    if store.upload_expired(owner, item_id):
        return ApiError(
            404,
            "input_expired",
            f"{what} {item_id!r} expired and was deleted by the retention cleanup; upload it "
            "again (the same bytes get the same id)",
            field,
        )
    return ApiError(404, "not_found", f"no {what} {item_id!r} for this key", field)


def require_mesh(store: JobStore, owner: str, mesh_id: str, field: str) -> MeshView:
    m = store.get_mesh(owner, mesh_id)
    if m is None:
        raise missing_input(store, owner, mesh_id, "mesh", field)
    return m


def check_vertex(mesh: MeshView, index: int | None, field: str) -> None:
    n = int(mesh.report.get("n_vertices", 0))
    if index is not None and index >= n:
        raise ApiError(
            422, "vertex_out_of_range", f"{field} = {index}, but the mesh has {n} vertices", field
        )


def check_repairs(mesh: MeshView, field: str, granted: set[str]) -> None:
    """422 ``mesh_needs_repair`` unless every repair the mesh needs is ``granted``.

    An upload whose only faults are holes or boundary ears is stored with
    ``report.repairs_needed`` (see ``conformorph.pipelines.upload_validation.repairable_mesh``); a job
    runs on it only when it asks for those repairs (the request fields are named
    as the repairs). An upload that is a disk only after the preparation step carries
    ``report.preparation_needed`` and needs ``"prepare": "auto"``, which grants every repair.
    """
    if "prepare" in granted:
        return
    prep = mesh.report.get("preparation_needed")
    if prep and not mesh.report.get("repairs_needed"):
        raise ApiError(
            422,
            "mesh_needs_preparation",
            f'mesh {mesh.id} is a disk only after preparation ({prep}); pass "prepare": "auto"',
            field,
        )
    needed = mesh.report.get("repairs_needed") or {}
    missing = [r for r in needed if r not in granted]
    if not missing:
        return
    what = []
    if "fill_holes" in needed:
        what.append(f"{needed['fill_holes']} hole(s)")
    if "remove_ears" in needed:
        ears = needed["remove_ears"]
        what.append(f"{len(ears)} boundary ear vertices ({ears[:10]})")
    how = "pass " + " and ".join(f"{r}: true" for r in missing) + ' (or "prepare": "auto")'
    raise ApiError(
        422,
        "mesh_needs_repair",
        f"mesh {mesh.id} is a disk only after repairs: it has {' and '.join(what)}; {how}",
        field,
    )


def check_interior_vertex(mesh: MeshView, field: str) -> None:
    """422 ``no_interior_vertex`` for a mesh whose every vertex is on its boundary.

    Reconstruction solves for the interior vertices from (H, lambda) with the
    boundary held fixed, so such a mesh has nothing to reconstruct. The count is
    ``report.interior_vertices`` (from the upload's validation); reports of older
    uploads lack it, and then nothing is checked here.
    """
    if mesh.report.get("interior_vertices") == 0:
        n = int(mesh.report.get("n_vertices", 0))
        raise ApiError(
            422,
            "no_interior_vertex",
            f"mesh {mesh.id} has no interior vertex (all {n} vertices are on its boundary), "
            "so there is no surface to reconstruct; its conformal map is allowed",
            field,
        )


def mesh_param(m: MeshView) -> dict[str, Any]:
    return {
        "id": m.id,
        "storage_key": m.storage_key,
        "file_type": m.file_type,
        "filename": m.filename,  # names the key in the GLBs (its stem)
    }


def check_frame_limit(frames: int, settings: Settings) -> None:
    """422 ``too_many_frames`` when a morph asks for more than ``settings.max_frames``."""
    if frames > settings.max_frames:
        raise ApiError(
            422,
            "too_many_frames",
            f"{frames} frames; the limit is {settings.max_frames}",
            "frames",
        )


def _canon(x: Any) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"))


async def checked_callback(
    fields: CallbackFields | None, settings: Settings
) -> tuple[str, str | None] | None:
    """The request's ``(callback_url, callback_secret)``, its destination checked
    against ``CONFORMORPH_CALLBACK_ALLOW`` (the name resolved off the event loop);
    422 ``callback_not_allowed`` when it is malformed or not allowed."""
    if fields is None:
        return None
    callback = fields.callback()
    if callback is None:
        if fields.callback_secret is not None:
            raise ApiError(
                422, "validation_error", "callback_secret needs a callback_url", "callback_secret"
            )
        return None
    policy = CallbackPolicy.parse(settings.callback_allow)
    try:
        await run_in_threadpool(check_destination, callback[0], policy)
    except CallbackRefused as exc:
        raise ApiError(422, "callback_not_allowed", str(exc), "callback_url") from exc
    return callback


async def submit_job(
    *,
    kind: str,
    params: dict[str, Any],
    owner: str,
    idempotency_key: str | None,
    store: JobStore,
    tasks: AsyncTasks,
    settings: Settings,
    response: Response,
    callback: tuple[str, str | None] | None = None,
) -> JobPublic:
    """Create (or find, by idempotency key) a job and send it to the workers.

    ``callback``: the checked ``(url, secret)`` of the job's webhook (the URL is also
    kept in the job's parameters, the secret only in the webhook row).
    """
    if callback is not None:
        params = {**params, "callback_url": callback[0]}
    if idempotency_key is not None and (
        not 1 <= len(idempotency_key) <= 200 or _CONTROL.search(idempotency_key)
    ):
        raise ApiError(
            422,
            "validation_error",
            "Idempotency-Key must be 1-200 characters, none of them a control character",
            "Idempotency-Key",
        )
    sealed = None
    if callback is not None and callback[1] is not None:
        sealed = await run_in_threadpool(lambda: box_for(settings).seal(callback[1]))
    # the limit check and the insert are one atomic step in the job store (issue 15 item 3)
    try:
        job, created = await run_in_threadpool(
            lambda: store.create_job(
                owner=owner,
                kind=kind,
                params=params,
                idempotency_key=idempotency_key,
                queued_lease_seconds=settings.queued_requeue_seconds,
                max_active=settings.max_active_jobs,
                # the secret is stored encrypted (worker/secret_box.py)
                callback=None if callback is None else (callback[0], sealed),
            )
        )
    except TooManyActiveJobs as exc:
        raise ApiError(429, "too_many_jobs", str(exc), headers={"Retry-After": "5"}) from exc
    except InputGone as exc:
        raise ApiError(404, "input_expired", str(exc)) from exc
    if not created and (job.kind != kind or _canon(job.params) != _canon(params)):
        raise ApiError(
            409,
            "idempotency_conflict",
            "this Idempotency-Key was used for a different request",
            "Idempotency-Key",
        )
    if created:
        try:
            await tasks.submit_job(job.id, job.stages)
        except Exception as exc:  # noqa: BLE001 - the broker refused: the job cannot run
            # the key is released with it: a retry with the same key makes a new job
            error = {"type": "broker_unavailable", "message": str(exc), "field": None}
            await run_in_threadpool(
                lambda: store.fail_job(job.id, error, release_idempotency_key=True)
            )
            raise ApiError(
                503,
                "broker_unavailable",
                f"could not enqueue the job: {exc}; retry later (the same Idempotency-Key "
                "is free for the retry)",
                headers={"Retry-After": "5"},
            ) from exc
    response.status_code = 202 if created else 200
    response.headers["Location"] = f"/v1/jobs/{job.id}"
    cb = await run_in_threadpool(job_callback, store, job)
    return job_public(job, cb)


@dataclass(frozen=True)
class JobSubmission:
    """What a job route needs besides its body: the caller and the means to create the job."""

    owner: str
    settings: Settings
    store: JobStore
    tasks: AsyncTasks
    response: Response
    idempotency_key: str | None

    async def submit(
        self, kind: str, params: dict[str, Any], body: CallbackFields | None = None
    ) -> JobPublic:
        """:func:`submit_job` for this request: 202 (or 200 for a repeated key) + ``Location``.

        ``body``: the request, for its ``callback_url``/``callback_secret``
        (:class:`conformorph.service.schemas.CallbackFields`; a new job route inherits them
        and passes its body here).
        """
        callback = await checked_callback(body, self.settings)
        return await submit_job(
            callback=callback,
            kind=kind,
            params=params,
            owner=self.owner,
            idempotency_key=self.idempotency_key,
            store=self.store,
            tasks=self.tasks,
            settings=self.settings,
            response=self.response,
        )


async def get_job_submission(
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    tasks: TaskClientDep,
    response: Response,
    idempotency_key: Annotated[str | None, Header(alias="Idempotency-Key")] = None,
) -> JobSubmission:
    return JobSubmission(owner, settings, store, tasks, response, idempotency_key)


SubmissionDep = Annotated[JobSubmission, Depends(get_job_submission)]
