"""``POST /v1/conformal-maps``: a disk conformal map of an uploaded mesh, as a job."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.concurrency import run_in_threadpool

from conformorph.service.api.submit import (
    JOB_RESPONSES,
    SubmissionDep,
    check_repairs,
    check_vertex,
    mesh_param,
    require_mesh,
)
from conformorph.service.schemas import ConformalMapCreate, JobPublic
from conformorph.worker import names

router = APIRouter(prefix="/v1/conformal-maps", tags=["conformal maps"])


@router.post("", operation_id="create_conformal_map", status_code=202, responses=JOB_RESPONSES)
async def create_conformal_map(body: ConformalMapCreate, job: SubmissionDep) -> JobPublic:
    """Start a job computing the disk map (``disk_map.npz``: uv, faces) and ``quality.json``."""
    mesh = await run_in_threadpool(require_mesh, job.store, job.owner, body.mesh, "mesh")
    check_repairs(mesh, "mesh", body.repairs())
    check_vertex(mesh, body.center_vertex, "center_vertex")
    check_vertex(mesh, body.angle_vertex, "angle_vertex")
    params = {
        "mesh": mesh_param(mesh),
        "method": body.method,
        "center_vertex": body.center_vertex,
        "angle_vertex": body.angle_vertex,
        "refine_angles": body.refine_angles,
        "fill_holes": body.fill_holes,
        "remove_ears": body.remove_ears,
        "prepare": body.prepare,
        "vertex_budget": body.vertex_budget,
    }
    return await job.submit(names.KIND_CONFORMAL_MAP, params, body)
