"""What every upload route shares: spooling under a size limit, content-addressed
ids per owner, 200 (not 201) for a repeat, worker validation, and 404 for a
record the caller does not own.

Used by ``/v1/meshes``, ``/v1/shapes``, ``/v1/textures`` and ``/v1/landmarks``.
"""

from __future__ import annotations

import hashlib
import re
import time
import uuid
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, TypeVar

from fastapi import Depends, Response, UploadFile
from fastapi.concurrency import run_in_threadpool

from conformorph.service.api.deps import OwnerDep, SettingsDep, StorageDep, StoreDep, TaskClientDep
from conformorph.service.core.config import Settings
from conformorph.service.errors import ApiError
from conformorph.service.schemas import ErrorBody, is_item_id
from conformorph.service.task_client import AsyncTasks
from conformorph.worker.job_store import JobStore, MeshView, TextureView
from conformorph.worker.storage import Storage

_R = TypeVar("_R")
_V = TypeVar("_V", MeshView, TextureView)
_CHUNK = 1 << 20
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def spool_upload(upload: UploadFile, storage: Storage, max_bytes: int) -> tuple[Path, str, int]:
    """Copy an upload to the storage's staging folder; returns (path, sha256, size).

    Raises ApiError 413 (and leaves no file) once the upload passes ``max_bytes``.
    """
    dest = storage.staging_dir() / f"upload-{uuid.uuid4().hex}"
    h = hashlib.sha256()
    size = 0
    upload.file.seek(0)
    try:
        with open(dest, "wb") as out:
            while chunk := upload.file.read(_CHUNK):
                size += len(chunk)
                if size > max_bytes:
                    raise ApiError(
                        413,
                        "payload_too_large",
                        f"upload exceeds the limit of {max_bytes} bytes",
                        "file",
                    )
                h.update(chunk)
                out.write(chunk)
    except BaseException:
        dest.unlink(missing_ok=True)
        raise
    return dest, h.hexdigest(), size


@dataclass(frozen=True)
class Spooled:
    """An upload copied to the staging folder."""

    path: Path
    sha256: str
    size: int


@asynccontextmanager
async def spooled(upload: UploadFile, storage: Storage, max_bytes: int) -> AsyncIterator[Spooled]:
    """The upload spooled to a staging file (413 above ``max_bytes``, 422 when empty),
    removed when the block ends (unless the block moved it away)."""
    path, digest, size = await run_in_threadpool(spool_upload, upload, storage, max_bytes)
    try:
        if size == 0:
            raise ApiError(422, "empty_file", "the uploaded file is empty", "file")
        yield Spooled(path, digest, size)
    finally:
        path.unlink(missing_ok=True)


#: bytes of uploads accepted for checking but not yet recorded, by (job store, owner): this
#: process's reservations against the storage quota (the API is one event loop)
_RESERVED: dict[tuple[int, str], int] = {}


@asynccontextmanager
async def quota_reserved(
    store: JobStore, owner: str, settings: Settings, size: int
) -> AsyncIterator[None]:
    """Reserve ``size`` bytes of ``owner``'s quota for the block (413 when they do not fit).

    The reservation is made before the stored total is read, and released when the
    block ends, after the upload is recorded (then counted by the store) or refused.
    Every concurrent upload of the key counts the others' reservations, so together
    they never pass the quota (issue 30: 40 concurrent 420 KB uploads against 3 MB
    stored 11.3 MB); a stored upload is briefly counted twice, which errs on the safe side.
    """
    key = (id(store), owner)
    others = _RESERVED.get(key, 0)
    _RESERVED[key] = others + size
    try:
        await check_quota(store, owner, settings, size, reserved=others)
        yield
    finally:
        left = _RESERVED[key] - size
        if left:
            _RESERVED[key] = left
        else:
            del _RESERVED[key]


async def check_quota(
    store: JobStore, owner: str, settings: Settings, size: int, *, reserved: int = 0
) -> None:
    """413 ``storage_quota_exceeded`` when storing ``size`` more bytes would take
    ``owner`` past ``settings.storage_quota_bytes`` (0: no quota).

    What a key stores is counted from the job store: its uploaded files plus every
    artifact of its jobs still on record (the retention cleanup frees both).
    413 (Content Too Large) because it is this content that cannot be taken, and
    the body says why and what to do (delete finished jobs, or wait for the
    retention cleanup); 429 would invite a retry that cannot succeed, and 403
    reads as a refused key. ``reserved``: bytes of the key's other uploads under
    way (:func:`quota_reserved`), counted as stored.
    """
    quota = settings.storage_quota_bytes
    if quota <= 0:
        return
    used = await run_in_threadpool(store.storage_used, owner) + reserved
    if used + size > quota:
        raise ApiError(
            413,
            "storage_quota_exceeded",
            f"this key stores {used} bytes; {size} more would pass its quota of {quota} bytes. "
            "Delete finished jobs (DELETE /v1/jobs/{job_id}) or wait for the retention cleanup",
            "file",
        )


#: the file type of a part whose filename has no extension, by its Content-Type
MEDIA_TYPE_EXTENSIONS = {
    "model/obj": "obj",
    "model/stl": "stl",
    "model/gltf-binary": "glb",
    "model/gltf+json": "gltf",
    "application/json": "json",
    "image/svg+xml": "svg",
}


def file_extension(
    filename: str | None, allowed: tuple[str, ...], content_type: str | None = None
) -> str:
    """The lower-case extension of ``filename`` (or, when the name has none, the one
    of the part's ``content_type``, see ``MEDIA_TYPE_EXTENSIONS``); ApiError 422
    unless it is ``allowed``."""
    ext = Path(filename or "").suffix.lower().lstrip(".")
    if not ext and content_type:
        ext = MEDIA_TYPE_EXTENSIONS.get(content_type.split(";")[0].strip().lower(), "")
    if ext not in allowed:
        raise ApiError(
            422,
            "unsupported_file_type",
            f"file name {filename!r} has no supported extension; expected one of "
            + ", ".join("." + a for a in allowed),
            "file",
        )
    return ext


def stored_filename(filename: str | None, default: str) -> str:
    """The client's file name as kept in a record: base name only, without control
    characters (PostgreSQL refuses NUL in text), at most 300 characters."""
    name = Path(_CONTROL.sub("", filename or "")).name[:300]
    return name or default


def content_id(owner: str, content: str, kind: str | None = None) -> str:
    """The id of an upload: a hash of the owner, the kind (when the kind has its own
    id space) and the content (its sha256, or a canonical text), so the same
    bytes from the same owner always get the same id and other owners another."""
    scoped = f"{owner}:{content}" if kind is None else f"{owner}:{kind}:{content}"
    return hashlib.sha256(scoped.encode()).hexdigest()[:32]


async def find_repeat(
    get: Callable[[str, str], _R | None], owner: str, item_id: str, response: Response
) -> _R | None:
    """The owner's record already stored under ``item_id``, answering 200 instead of
    the route's 201 when there is one; None for a new upload."""
    existing = await run_in_threadpool(get, owner, item_id)
    if existing is not None:
        response.status_code = 200
    return existing


async def add_once(add: Callable[[_V], _V], view: _V, response: Response) -> _V:
    """Store ``view`` (``add`` inserts, or returns the record already stored under the
    same id); answers 200 instead of 201 when another request stored it first, so
    that of many concurrent uploads of the same bytes exactly one is a 201."""
    stored = await run_in_threadpool(add, view)
    if stored.created_at != view.created_at:
        response.status_code = 200
    return stored


async def get_owned(
    get: Callable[[str, str], _R | None], owner: str, item_id: str, what: str, field: str
) -> _R:
    """The owner's record ``item_id``; ApiError 404 when it is missing or someone else's
    (or when ``item_id`` cannot be one of our ids, without asking the store)."""
    found = await run_in_threadpool(get, owner, item_id) if is_item_id(item_id) else None
    if found is None:
        raise ApiError(404, "not_found", f"no {what} {item_id!r}", field)
    return found


async def keep_validated(
    storage: Storage,
    staged: Path,
    owner: str,
    ext: str,
    key: str,
    validate: Callable[[str], Awaitable[dict[str, Any]]],
    what: str,
) -> dict[str, Any]:
    """Have a worker validate a staged upload, then keep it under ``key``.

    The file goes to a pending storage key first (the worker reads it there),
    ``validate(pending_key)`` answers ``{"ok", "report"}`` or ``{"ok": False,
    "error"}``; a rejection becomes its ApiError (422 ``invalid_<what>`` unless
    the worker says otherwise). The pending key is always removed. Returns the
    worker's report.
    """
    pending = f"uploads/{owner}/{uuid.uuid4().hex}.{ext}"
    await run_in_threadpool(storage.put_file, pending, staged, move=True)
    try:
        result = await validate(pending)
        if not result.get("ok"):
            err = result.get("error") or {}
            raise ApiError(
                int(err.get("status", 422)),
                str(err.get("type", f"invalid_{what}")),
                str(err.get("message", f"invalid {what}")),
                err.get("field", "file"),
            )
        await run_in_threadpool(storage.put_file, key, storage.local_path(pending), move=True)
    finally:
        storage.delete(pending)
    return dict(result.get("report") or {})


@dataclass(frozen=True)
class UploadRequest:
    """What an upload route needs besides its file: the caller, limits, and where
    the upload is validated and kept."""

    owner: str
    settings: Settings
    store: JobStore
    storage: Storage
    tasks: AsyncTasks
    response: Response


async def get_upload_request(
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    storage: StorageDep,
    tasks: TaskClientDep,
    response: Response,
) -> UploadRequest:
    return UploadRequest(owner, settings, store, storage, tasks, response)


UploadRequestDep = Annotated[UploadRequest, Depends(get_upload_request)]


async def upload_validated_file(
    upload: UploadFile,
    request: UploadRequest,
    *,
    kind: str,
    allowed: tuple[str, ...],
    id_space: str | None,
    get: Callable[[str, str], MeshView | None],
    add: Callable[[MeshView], MeshView],
    validate: Callable[[str, str], Awaitable[dict[str, Any]]],
) -> MeshView:
    """The whole upload of a file a worker validates (meshes, shapes).

    Extension check, spooling (413 above ``settings.max_upload_bytes``, empty
    file), the content id in ``id_space``, the existing record on a repeat
    (200), else worker validation by ``validate(pending_key, ext)`` and a new
    record stored as ``<kind>s/<owner>/<id>.<ext>``.
    """
    owner, storage = request.owner, request.storage
    ext = file_extension(upload.filename, allowed, upload.content_type)
    async with spooled(upload, storage, request.settings.max_upload_bytes) as up:
        item_id = content_id(owner, up.sha256, id_space)
        existing = await find_repeat(get, owner, item_id, request.response)
        if existing is not None:
            return existing
        async with quota_reserved(request.store, owner, request.settings, up.size):
            key = f"{kind}s/{owner}/{item_id}.{ext}"
            report = await keep_validated(
                storage, up.path, owner, ext, key, lambda pending: validate(pending, ext), kind
            )
            view = MeshView(
                owner=owner,
                id=item_id,
                filename=stored_filename(upload.filename, f"{kind}.{ext}"),
                file_type=ext,
                storage_key=key,
                size_bytes=up.size,
                report=report,
                created_at=time.time(),
            )
            return await add_once(add, view, request.response)


def upload_errors(
    not_found: str, invalid: str, *, worker_validated: bool
) -> dict[int | str, dict[str, Any]]:
    """OpenAPI error ``responses`` of an upload kind's routes (upload and look-up).

    ``not_found`` and ``invalid`` describe its 404 and 422; ``worker_validated``
    adds the 503 of an upload a worker must check.
    """
    errors: dict[int | str, dict[str, Any]] = {
        401: {"model": ErrorBody, "description": "missing or unknown API key"},
        404: {"model": ErrorBody, "description": not_found},
        413: {
            "model": ErrorBody,
            "description": "upload larger than the limit, or past the key's storage quota "
            "(storage_quota_exceeded)",
        },
        422: {"model": ErrorBody, "description": invalid},
    }
    if worker_validated:
        errors[503] = {"model": ErrorBody, "description": "no worker available to validate"}
    return errors


def upload_body(allowed: tuple[str, ...]) -> dict[str, Any]:
    """OpenAPI ``openapi_extra`` of an upload route: the part content types that name
    a file type (a part whose filename has one of the route's extensions may have
    any content type)."""
    types = [t for t, e in MEDIA_TYPE_EXTENSIONS.items() if e in allowed]
    return {
        "requestBody": {
            "content": {
                "multipart/form-data": {"encoding": {"file": {"contentType": ", ".join(types)}}}
            }
        }
    }


def upload_responses(
    model: type[Any], errors: dict[int | str, dict[str, Any]]
) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` of an upload route: 200 for a repeat, then ``errors``."""
    return {200: {"model": model, "description": "already uploaded: same id"}, **errors}
