"""Turning job rows into their public JSON."""

from __future__ import annotations

from service.schemas import ArtifactLink, JobError, JobLinks, JobPublic, StageInfo
from worker.job_store import JobView


def _stage_state(job: JobView, stage: str) -> str:
    if stage in job.stages_done:
        return "done"
    if job.stage == stage:
        if job.state == "running":
            return "running"
        if job.state in ("failed", "cancelled"):
            return job.state
    return "pending"


def public_params(params: dict[str, object]) -> dict[str, object]:
    """Job parameters without internal storage keys."""
    out: dict[str, object] = {}
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


def job_public(job: JobView) -> JobPublic:
    base = f"/v1/jobs/{job.id}"
    return JobPublic(
        id=job.id,
        kind=job.kind,
        state=job.state,  # type: ignore[arg-type]
        stage=job.stage,
        progress=round(job.progress, 4),
        stages=[
            StageInfo(
                name=s,
                state=_stage_state(job, s),  # type: ignore[arg-type]
                seconds=job.stage_seconds.get(s),
            )
            for s in job.stages
        ],
        created_at=job.created_at,
        started_at=job.started_at,
        finished_at=job.finished_at,
        error=JobError(**job.error) if job.error else None,
        artifacts=[
            ArtifactLink(
                name=name,
                url=f"{base}/artifacts/{name}",
                content_type=str(rec["content_type"]),
                size=int(rec["size"]),
                etag=str(rec["etag"]),
            )
            for name, rec in sorted(job.artifacts.items())
            if not rec.get("internal")
        ],
        params=public_params(job.params),
        links=JobLinks(self=base, events=f"{base}/events"),
    )
