"""``/v1/meshes``: upload (validated by a worker before it is stored) and look-up."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, UploadFile

from conformorph.service.api.deps import OwnerDep, StoreDep
from conformorph.service.api.uploads import (
    UploadRequestDep,
    get_owned,
    upload_body,
    upload_errors,
    upload_responses,
    upload_validated_file,
)
from conformorph.service.schemas import MeshPublic
from conformorph.worker.job_store import MeshView

router = APIRouter(prefix="/v1/meshes", tags=["meshes"])

MESH_TYPES = ("obj", "ply", "off", "stl", "glb", "gltf")

ERRORS = upload_errors(
    "no such mesh for this key", "not a valid disk-topology triangle mesh", worker_validated=True
)


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


@router.post(
    "",
    operation_id="upload_mesh",
    status_code=201,
    openapi_extra=upload_body(MESH_TYPES),
    responses=upload_responses(MeshPublic, ERRORS),
)
async def upload_mesh(
    file: Annotated[
        UploadFile,
        File(
            description="OBJ, PLY, OFF, STL, GLB or glTF mesh, not empty; the part's filename "
            "must end in .obj, .ply, .off, .stl, .glb or .gltf (422 unsupported_file_type)",
            json_schema_extra={"minLength": 1},
        ),
    ],
    req: UploadRequestDep,
) -> MeshPublic:
    """Upload a mesh; it is read and validated (disk topology, manifold, ...) before it is kept."""
    view = await upload_validated_file(
        file,
        req,
        kind="mesh",
        allowed=MESH_TYPES,
        id_space=None,
        get=req.store.get_mesh,
        add=req.store.add_mesh,
        validate=lambda pending, ext: req.tasks.validate_mesh(
            pending,
            ext,
            req.settings.max_vertices,
            req.settings.max_faces,
            owner=req.owner,
        ),
    )
    if req.response.status_code != 200:  # a new mesh (201): its per-mesh work, in the background
        await req.tasks.precompute_key(view.owner, view.id)
    return mesh_public(view)


@router.get("/{mesh_id}", operation_id="get_mesh", responses=ERRORS)
async def get_mesh(mesh_id: str, owner: OwnerDep, store: StoreDep) -> MeshPublic:
    """An uploaded mesh's record (404 for other keys' meshes)."""
    return mesh_public(await get_owned(store.get_mesh, owner, mesh_id, "mesh", "mesh_id"))
