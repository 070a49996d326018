"""``/v1/shapes``: 2D shapes (JSON rings or SVG paths) for ``/v1/morphs2d``, validated by a worker."""

from __future__ import annotations

import hashlib
import time
import uuid
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, File, Response, UploadFile
from fastapi.concurrency import run_in_threadpool

from service.api.deps import OwnerDep, SettingsDep, StorageDep, StoreDep, TaskClientDep
from service.api.routes.meshes import ERRORS, _ext_of, spool_upload
from service.errors import ApiError
from service.schemas import ShapePublic
from worker.job_store import MeshView

router = APIRouter(prefix="/v1/shapes", tags=["shapes"])

SHAPE_TYPES = ("json", "svg")


def shape_public(m: MeshView) -> ShapePublic:
    return ShapePublic(
        id=m.id,
        filename=m.filename,
        file_type=m.file_type,
        size_bytes=m.size_bytes,
        rings=int(m.report.get("rings", 0)),
        points=int(m.report.get("points", 0)),
        report=m.report,
        created_at=m.created_at,
    )


@router.post(
    "",
    operation_id="upload_shape",
    status_code=201,
    responses={200: {"model": ShapePublic, "description": "already uploaded: same id"}, **ERRORS},
)
async def upload_shape(
    file: Annotated[UploadFile, File(description='JSON {"rings": [...]} or SVG path data')],
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    storage: StorageDep,
    tasks: TaskClientDep,
    response: Response,
) -> ShapePublic:
    """Upload a 2D shape; its rings are read and validated before it is kept."""
    ext = _ext_of(file.filename, SHAPE_TYPES)
    staged, digest, size = await run_in_threadpool(
        spool_upload, file, storage, settings.max_upload_bytes
    )
    try:
        if size == 0:
            raise ApiError(422, "empty_file", "the uploaded file is empty", "file")
        shape_id = hashlib.sha256(f"{owner}:shape:{digest}".encode()).hexdigest()[:32]
        existing = await run_in_threadpool(store.get_shape, owner, shape_id)
        if existing is not None:
            response.status_code = 200
            return shape_public(existing)
        pending = f"uploads/{owner}/{uuid.uuid4().hex}.{ext}"
        await run_in_threadpool(storage.put_file, pending, staged, move=True)
        try:
            result = await run_in_threadpool(
                tasks.validate_shape, pending, settings.validate_timeout
            )
            if not result.get("ok"):
                err = result.get("error") or {}
                raise ApiError(
                    int(err.get("status", 422)),
                    str(err.get("type", "invalid_shape")),
                    str(err.get("message", "invalid shape")),
                    err.get("field", "file"),
                )
            key = f"shapes/{owner}/{shape_id}.{ext}"
            await run_in_threadpool(storage.put_file, key, storage.local_path(pending), move=True)
        finally:
            storage.delete(pending)
        view = MeshView(
            owner=owner,
            id=shape_id,
            filename=Path(file.filename or f"shape.{ext}").name[:300],
            file_type=ext,
            storage_key=key,
            size_bytes=size,
            report=dict(result.get("report") or {}),
            created_at=time.time(),
        )
        return shape_public(await run_in_threadpool(store.add_shape, view))
    finally:
        staged.unlink(missing_ok=True)


@router.get("/{shape_id}", operation_id="get_shape", responses=ERRORS)
async def get_shape(shape_id: str, owner: OwnerDep, store: StoreDep) -> ShapePublic:
    """An uploaded shape's record (404 for other keys' shapes)."""
    m = await run_in_threadpool(store.get_shape, owner, shape_id)
    if m is None:
        raise ApiError(404, "not_found", f"no shape {shape_id!r}", "shape_id")
    return shape_public(m)
