"""``/v1/jobs``: state, listing, cancel/delete, server-sent events, artifacts."""

from __future__ import annotations

import asyncio
import json
import re
from collections.abc import AsyncIterator
from typing import Annotated, Any, BinaryIO

from fastapi import APIRouter, Header, Path, Query, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import StreamingResponse

from conformorph.service.api.deps import OwnerDep, SettingsDep, StorageDep, StoreDep, TaskClientDep
from conformorph.service.api.view import job_callback, job_public
from conformorph.service.errors import ApiError
from conformorph.service.schemas import ErrorBody, JobList, JobPublic, JobState, is_item_id
from conformorph.worker import names
from conformorph.worker.job_record import public_params
from conformorph.worker.job_store import JobStore, JobView
from conformorph.worker.storage import ArtifactNotFound, DirectDownloads, Storage

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])

ERRORS: dict[int | str, dict[str, object]] = {
    401: {"model": ErrorBody, "description": "missing or unknown API key"},
    404: {"model": ErrorBody, "description": "no such job for this key"},
}
JobId = Annotated[str, Path(min_length=1, max_length=64)]
_CHUNK = 256 * 1024
#: every content type an artifact is served with (the stages' artifact records)
ARTIFACT_TYPES = (
    "application/json",
    "model/gltf-binary",
    "model/gltf+json",
    "model/obj",
    "image/png",
    "image/jpeg",
    "image/gif",
    "image/svg+xml",
    "text/csv",
    "application/octet-stream",
)
_RANGE_RE = re.compile(r"^bytes=(\d*)-(\d*)$")


def _job_or_404(store: JobStore, job_id: str, owner: str) -> JobView:
    # an id we cannot have made is not looked up (PostgreSQL refuses NUL in text)
    job = store.get_job(job_id, owner) if is_item_id(job_id) else None
    if job is None:
        raise ApiError(404, "not_found", f"no job {job_id!r}", "job_id")
    return job


@router.get("", operation_id="list_jobs", responses=ERRORS)
async def list_jobs(
    owner: OwnerDep,
    store: StoreDep,
    state: Annotated[JobState | None, Query(description="only jobs in this state")] = None,
    limit: Annotated[int, Query(ge=1, le=200)] = 50,
    offset: Annotated[int, Query(ge=0, le=1_000_000)] = 0,
) -> JobList:
    """The caller's jobs, newest first."""

    def page() -> tuple[list[JobPublic], int]:
        jobs, total = store.list_jobs(owner, state=state, limit=limit, offset=offset)
        return [job_public(j, job_callback(store, j)) for j in jobs], total

    items, total = await run_in_threadpool(page)
    return JobList(items=items, total=total, limit=limit, offset=offset)


@router.get("/{job_id}", operation_id="get_job", response_model=JobPublic, responses=ERRORS)
async def get_job(job_id: JobId, owner: OwnerDep, store: StoreDep) -> Response:
    """State, current stage, progress, seconds per stage, error, artifact links."""
    job = await run_in_threadpool(_job_or_404, store, job_id, owner)
    # only a job created with a callback_url costs a second read (its webhook row)
    cb = (
        await run_in_threadpool(job_callback, store, job)
        if job.params.get("callback_url")
        else None
    )
    # the hot path: serialise once (the model is already validated on construction)
    return Response(job_public(job, cb).model_dump_json(), media_type="application/json")


@router.get(
    "/{job_id}/params",
    operation_id="get_job_params",
    response_model=dict[str, Any],
    responses=ERRORS,
)
async def get_job_params(job_id: JobId, owner: OwnerDep, store: StoreDep) -> Response:
    """Every parameter of the job whole, including those the job record shows by
    reference (``{"ref": "/v1/jobs/{id}/params#/<key>", "entries": n}``: values whose
    JSON exceeds 4 KB, such as a long anchor ``paths`` list)."""
    job = await run_in_threadpool(_job_or_404, store, job_id, owner)
    body = await run_in_threadpool(lambda: json.dumps(public_params(job.params)))
    return Response(body, media_type="application/json")


@router.delete(
    "/{job_id}",
    operation_id="delete_job",
    responses={
        200: {"model": JobPublic, "description": "the job was cancelled"},
        204: {"description": "the finished job and its artifacts were deleted"},
        **ERRORS,
    },
    response_model=None,
)
async def delete_job(
    job_id: JobId, owner: OwnerDep, store: StoreDep, storage: StorageDep, tasks: TaskClientDep
) -> JobPublic | Response:
    """Cancel a queued or running job (200, its new state), or delete a finished one (204)."""
    job = await run_in_threadpool(_job_or_404, store, job_id, owner)
    if job.state in names.ACTIVE_STATES:
        after = await run_in_threadpool(store.cancel_job, job_id, owner)
        if job.task_id:
            try:
                await tasks.cancel(job.task_id)
            except Exception:  # noqa: BLE001,S110 - best effort: the job row already says cancelled
                pass
        if after is not None and after.state in names.ACTIVE_STATES:
            after = await run_in_threadpool(store.cancel_job, job_id, owner)
        return job_public(after or job)
    # storage first: when the store cannot be reached (503, StorageUnavailable) the job
    # and its record stay, and a retry deletes both; nothing is orphaned
    await run_in_threadpool(storage.delete_prefix, f"jobs/{job_id}")
    await run_in_threadpool(store.delete_job, job_id, owner)
    return Response(status_code=204)


def _snapshot(job: JobView) -> tuple[str, str | None, float]:
    return job.state, job.stage, round(job.progress, 3)


@router.get(
    "/{job_id}/events",
    operation_id="job_events",
    response_class=StreamingResponse,
    responses={
        200: {"content": {"text/event-stream": {}}, "description": "state and progress events"},
        **ERRORS,
    },
)
async def job_events(
    job_id: JobId, request: Request, owner: OwnerDep, store: StoreDep, settings: SettingsDep
) -> StreamingResponse:
    """Server-sent events: one ``state`` event per change of state, stage or progress; ends when the job does."""
    first = await run_in_threadpool(_job_or_404, store, job_id, owner)

    async def stream() -> AsyncIterator[str]:
        job: JobView | None = first
        last: tuple[str, str | None, float] | None = None
        idle = 0.0
        yield "retry: 1000\n\n"
        while job is not None:
            snap = _snapshot(job)
            if snap != last:
                last = snap
                idle = 0.0
                body = job_public(job).model_dump(mode="json")
                yield f"event: state\nid: {job.updated_at:.6f}\ndata: {json.dumps(body)}\n\n"
            if job.state in names.TERMINAL_STATES:
                yield "event: end\ndata: {}\n\n"
                return
            if await request.is_disconnected():
                return
            await asyncio.sleep(settings.events_poll_seconds)
            idle += settings.events_poll_seconds
            if idle >= 15.0:
                idle = 0.0
                yield ": keep-alive\n\n"
            job = await run_in_threadpool(store.get_job, job_id, owner)
        yield "event: end\ndata: {}\n\n"

    return StreamingResponse(
        stream(),
        media_type="text/event-stream",
        headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"},
    )


def _range_number(digits: str) -> int:
    """A Range header's decimal number, however many digits it has: one past any
    size we can store when it has more than 18 significant digits (no int() of
    thousands of digits, which Python refuses above 4300)."""
    digits = digits.lstrip("0") or "0"
    return int(digits) if len(digits) <= 18 else 10**18


def _parse_range(header: str, size: int) -> tuple[int, int] | None:
    """The (start, end inclusive) of a single ``bytes=`` range; None to serve it whole.

    RFC 9110 section 14.2: a Range that does not parse (other units, several
    ranges, junk) is ignored; a parsable one that selects nothing is a 416.
    """
    m = _RANGE_RE.match(header.strip())
    if m is None:
        return None  # multi-range or other units: serve the whole body (RFC 9110 allows it)
    a, b = m.groups()
    if a == "" and b == "":
        return None
    if a == "":
        n = _range_number(b)
        if n == 0:
            raise ApiError(
                416,
                "range_not_satisfiable",
                "empty suffix range",
                "Range",
                headers={"Content-Range": f"bytes */{size}"},
            )
        return max(0, size - n), size - 1
    start = _range_number(a)
    if b != "" and _range_number(b) < start:
        return None  # last < first: an invalid range-spec, ignored (RFC 9110 14.1.1)
    end = size - 1 if b == "" else min(_range_number(b), size - 1)
    if start >= size:
        raise ApiError(
            416,
            "range_not_satisfiable",
            f"range starts at byte {_short(a)}, past the artifact's {size} bytes",
            "Range",
            headers={"Content-Range": f"bytes */{size}"},
        )
    return start, end


def _short(digits: str) -> str:
    """A number from a header as shown in a message (at most 40 characters)."""
    return digits if len(digits) <= 40 else f"{digits[:20]}...({len(digits)} digits)"


def _iter_file(f: BinaryIO, start: int, length: int) -> AsyncIterator[bytes]:
    """The bytes ``start`` … ``start + length`` of the open file ``f`` (opened before the
    response starts, so that a store that cannot be reached is a 503, not a cut stream)."""

    async def gen() -> AsyncIterator[bytes]:
        try:
            await run_in_threadpool(f.seek, start)
            left = length
            while left > 0:
                chunk = await run_in_threadpool(f.read, min(_CHUNK, left))
                if not chunk:
                    break
                left -= len(chunk)
                yield chunk
        finally:
            f.close()

    return gen()


_ARTIFACT_RESPONSES: dict[int | str, dict[str, object]] = {
    206: {"description": "the requested byte range"},
    304: {"description": "not modified (If-None-Match)"},
    416: {"model": ErrorBody, "description": "range not satisfiable"},
    **ERRORS,
}


async def _artifact(
    job_id: str,
    name: str,
    owner: str,
    store: JobStore,
    storage: Storage,
    range_: str | None,
    if_none_match: str | None,
    *,
    body: bool,
) -> Response:
    """The artifact's response: headers, status and (for GET) the bytes."""
    job = await run_in_threadpool(_job_or_404, store, job_id, owner)
    rec = job.artifacts.get(name)
    if rec is None or rec.get("internal"):
        raise ApiError(404, "not_found", f"job {job_id!r} has no artifact {name!r}", "name")
    key, etag, ctype = str(rec["key"]), f'"{rec["etag"]}"', str(rec["content_type"])
    try:
        size = await run_in_threadpool(storage.size, key)
    except ArtifactNotFound as exc:
        raise ApiError(404, "not_found", f"artifact {name!r} is no longer stored", "name") from exc
    headers = {"ETag": etag, "Accept-Ranges": "bytes", "Cache-Control": "private, max-age=3600"}
    if if_none_match is not None and (
        if_none_match.strip() == "*"
        or etag in [t.strip().removeprefix("W/") for t in if_none_match.split(",")]
    ):
        return Response(status_code=304, headers=headers)
    if body and isinstance(storage, DirectDownloads):
        url = await run_in_threadpool(storage.download_url, key, ctype)
        if url is not None:  # the object store serves the bytes and the Range itself
            redirect = {"Location": url, "ETag": etag, "Cache-Control": "private, no-store"}
            return Response(status_code=307, headers=redirect)
    rng = _parse_range(range_, size) if range_ else None
    start, end, status = (0, size - 1, 200) if rng is None else (*rng, 206)
    if rng is not None:
        headers["Content-Range"] = f"bytes {start}-{end}/{size}"
    headers["Content-Length"] = str(end - start + 1)
    if not body:  # HEAD: the same headers (Content-Length kept as set), no bytes
        return Response(status_code=status, media_type=ctype, headers=headers)
    try:
        f = await run_in_threadpool(storage.open, key)
    except ArtifactNotFound as exc:
        raise ApiError(404, "not_found", f"artifact {name!r} is no longer stored", "name") from exc
    return StreamingResponse(
        _iter_file(f, start, end - start + 1),
        status_code=status,
        media_type=ctype,
        headers=headers,
    )


ArtifactName = Annotated[str, Path(min_length=1, max_length=300)]
RangeHeader = Annotated[str | None, Header(alias="Range")]
IfNoneMatchHeader = Annotated[str | None, Header(alias="If-None-Match")]


@router.get(
    "/{job_id}/artifacts/{name:path}",
    operation_id="get_artifact",
    response_class=StreamingResponse,
    responses={
        200: {
            "content": {t: {} for t in ARTIFACT_TYPES},
            "description": "the artifact, with its own content type (metrics.json, "
            "quality.json, errors.json: application/json; *.glb: model/gltf-binary; …)",
        },
        307: {
            "description": "on object storage with CONFORMORPH_S3_DOWNLOADS=redirect: the "
            "artifact is at the presigned URL in Location"
        },
        **_ARTIFACT_RESPONSES,
    },
)
async def get_artifact(
    job_id: JobId,
    name: ArtifactName,
    owner: OwnerDep,
    store: StoreDep,
    storage: StorageDep,
    range_: RangeHeader = None,
    if_none_match: IfNoneMatchHeader = None,
) -> Response:
    """An artifact with its content type, a strong ETag, and single byte-range support."""
    return await _artifact(job_id, name, owner, store, storage, range_, if_none_match, body=True)


@router.head(
    "/{job_id}/artifacts/{name:path}",
    operation_id="head_artifact",
    responses={
        200: {"description": "the artifact's headers (Content-Length, ETag, …), no body"},
        **_ARTIFACT_RESPONSES,
    },
)
async def head_artifact(
    job_id: JobId,
    name: ArtifactName,
    owner: OwnerDep,
    store: StoreDep,
    storage: StorageDep,
    range_: RangeHeader = None,
    if_none_match: IfNoneMatchHeader = None,
) -> Response:
    """The headers ``GET`` would send for the artifact (size, type, ETag, range), no body."""
    return await _artifact(job_id, name, owner, store, storage, range_, if_none_match, body=False)
