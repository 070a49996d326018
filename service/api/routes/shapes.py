"""``/v1/shapes``: 2D shapes (JSON rings or SVG paths) for ``/v1/morphs2d``, validated by a worker."""

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
from conformorph.service.schemas import ShapePublic
from conformorph.worker.job_store import MeshView

router = APIRouter(prefix="/v1/shapes", tags=["shapes"])

SHAPE_TYPES = ("json", "svg")

ERRORS = upload_errors(
    "no such shape for this key",
    "not a JSON or SVG 2D shape of simple, non-crossing rings "
    "(3+ points, non-zero area, holes inside the outer ring)",
    worker_validated=True,
)


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
    openapi_extra=upload_body(SHAPE_TYPES),
    responses=upload_responses(ShapePublic, ERRORS),
)
async def upload_shape(
    file: Annotated[
        UploadFile,
        File(
            description='JSON {"rings": [...]} or SVG path data, not empty; the part\'s '
            "filename must end in .json or .svg (422 unsupported_file_type)",
            json_schema_extra={"minLength": 1},
        ),
    ],
    req: UploadRequestDep,
) -> ShapePublic:
    """Upload a 2D shape; its rings are read and validated before it is kept."""
    view = await upload_validated_file(
        file,
        req,
        kind="shape",
        allowed=SHAPE_TYPES,
        id_space="shape",
        get=req.store.get_shape,
        add=req.store.add_shape,
        validate=lambda pending, _ext: req.tasks.validate_shape(
            pending, req.settings.max_shape_points, owner=req.owner
        ),
    )
    return shape_public(view)


@router.get("/{shape_id}", operation_id="get_shape", responses=ERRORS)
async def get_shape(shape_id: str, owner: OwnerDep, store: StoreDep) -> ShapePublic:
    """An uploaded shape's record (404 for other keys' shapes)."""
    return shape_public(await get_owned(store.get_shape, owner, shape_id, "shape", "shape_id"))
