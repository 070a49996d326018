"""``/v1/meshes``: upload (validated by a worker before it is stored) and look-up."""

from __future__ import annotations

import hashlib
import time
import uuid
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, File, Response, UploadFile
from fastapi.concurrency import run_in_threadpool

from service.api.deps import OwnerDep, SettingsDep, StorageDep, StoreDep, TaskClientDep
from service.errors import ApiError
from service.schemas import ErrorBody, MeshPublic
from worker.job_store import MeshView
from worker.storage import Storage

router = APIRouter(prefix="/v1/meshes", tags=["meshes"])

MESH_TYPES = ("obj", "ply", "off", "stl", "glb", "gltf")
_CHUNK = 1 << 20

ERRORS: dict[int | str, dict[str, object]] = {
    401: {"model": ErrorBody, "description": "missing or unknown API key"},
    404: {"model": ErrorBody, "description": "no such mesh for this key"},
    413: {"model": ErrorBody, "description": "upload larger than the limit"},
    422: {"model": ErrorBody, "description": "not a valid disk-topology triangle mesh"},
    503: {"model": ErrorBody, "description": "no worker available to validate"},
}


def mesh_public(m: MeshView) -> MeshPublic:
    r = m.report
    return MeshPublic(
        id=m.id,
        filename=m.filename,
        file_type=m.file_type,
        size_bytes=m.size_bytes,
        vertices=int(r.get("n_vertices", 0)),
        faces=int(r.get("n_faces", 0)),
        boundary_loops=r.get("boundary_loops"),
        euler_characteristic=r.get("euler_characteristic"),
        report=r,
        created_at=m.created_at,
    )


def spool_upload(upload: UploadFile, storage: Storage, max_bytes: int) -> tuple[Path, str, int]:
    """Copy an upload to the storage's staging folder; returns (path, sha256, size)."""
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


def _ext_of(filename: str | None, allowed: tuple[str, ...]) -> str:
    ext = Path(filename or "").suffix.lower().lstrip(".")
    if ext not in allowed:
        raise ApiError(
            422,
            "unsupported_file_type",
            f"file name {filename!r} has no supported extension; expected one of "
            + ", ".join("." + a for a in allowed),
            "file",
        )
    return ext


@router.post(
    "",
    operation_id="upload_mesh",
    status_code=201,
    responses={200: {"model": MeshPublic, "description": "already uploaded: same id"}, **ERRORS},
)
async def upload_mesh(
    file: Annotated[UploadFile, File(description="OBJ, PLY, OFF, STL or GLB mesh")],
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    storage: StorageDep,
    tasks: TaskClientDep,
    response: Response,
) -> MeshPublic:
    """Upload a mesh; it is read and validated (disk topology, manifold, ...) before it is kept."""
    ext = _ext_of(file.filename, MESH_TYPES)
    staged, digest, size = await run_in_threadpool(
        spool_upload, file, storage, settings.max_upload_bytes
    )
    try:
        if size == 0:
            raise ApiError(422, "empty_file", "the uploaded file is empty", "file")
        mesh_id = hashlib.sha256(f"{owner}:{digest}".encode()).hexdigest()[:32]
        existing = await run_in_threadpool(store.get_mesh, owner, mesh_id)
        if existing is not None:
            response.status_code = 200
            return mesh_public(existing)
        pending_key = f"uploads/{owner}/{uuid.uuid4().hex}.{ext}"
        await run_in_threadpool(storage.put_file, pending_key, staged, move=True)
        try:
            result = await run_in_threadpool(
                tasks.validate_mesh,
                pending_key,
                ext,
                settings.max_vertices,
                settings.max_faces,
                settings.validate_timeout,
            )
            if not result.get("ok"):
                err = result.get("error") or {}
                raise ApiError(
                    int(err.get("status", 422)),
                    str(err.get("type", "invalid_mesh")),
                    str(err.get("message", "invalid mesh")),
                    err.get("field", "file"),
                )
            key = f"meshes/{owner}/{mesh_id}.{ext}"
            src = storage.local_path(pending_key)
            await run_in_threadpool(storage.put_file, key, src, move=True)
        finally:
            storage.delete(pending_key)
        view = MeshView(
            owner=owner,
            id=mesh_id,
            filename=Path(file.filename or f"mesh.{ext}").name[:300],
            file_type=ext,
            storage_key=key,
            size_bytes=size,
            report=dict(result.get("report") or {}),
            created_at=time.time(),
        )
        return mesh_public(await run_in_threadpool(store.add_mesh, view))
    finally:
        staged.unlink(missing_ok=True)


@router.get("/{mesh_id}", operation_id="get_mesh", responses=ERRORS)
async def get_mesh(mesh_id: str, owner: OwnerDep, store: StoreDep) -> MeshPublic:
    """An uploaded mesh's record (404 for other keys' meshes)."""
    m = await run_in_threadpool(store.get_mesh, owner, mesh_id)
    if m is None:
        raise ApiError(404, "not_found", f"no mesh {mesh_id!r}", "mesh_id")
    return mesh_public(m)
