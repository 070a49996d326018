"""``POST /v1/reconstructions``: map, (H, λ), Algorithm 1 reconstruction, as a job."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.concurrency import run_in_threadpool

from conformorph.service.api.submit import (
    JOB_RESPONSES,
    SubmissionDep,
    check_interior_vertex,
    check_repairs,
    mesh_param,
    require_mesh,
)
from conformorph.service.schemas import JobPublic, ReconstructionCreate
from conformorph.worker import names

router = APIRouter(prefix="/v1/reconstructions", tags=["reconstructions"])


@router.post("", operation_id="create_reconstruction", status_code=202, responses=JOB_RESPONSES)
async def create_reconstruction(body: ReconstructionCreate, job: SubmissionDep) -> JobPublic:
    """Start a job: disk map, mean curvature and conformal factor, then the surface rebuilt
    from them alone (``reconstruction.obj`` in the input's vertex order, ``errors.json``)."""
    mesh = await run_in_threadpool(require_mesh, job.store, job.owner, body.mesh, "mesh")
    check_repairs(mesh, "mesh", body.repairs())
    check_interior_vertex(mesh, "mesh")
    # like ``conformorph reconstruct``: the map's folds are reported, not repaired,
    # since reconstruction needs no bijective map; and the harmonic map itself,
    # which the disk Laplacian rebuilds the surface from (no angle refinement)
    params = {
        "mesh": mesh_param(mesh),
        "method": body.method,
        "curvature": body.curvature,
        "fold_policy": "report",
        "refine_angles": False,
        "fold_correction": body.fold_correction,
        "fill_holes": body.fill_holes,
        "remove_ears": body.remove_ears,
        "prepare": body.prepare,
        "vertex_budget": body.vertex_budget,
    }
    return await job.submit(names.KIND_RECONSTRUCTION, params, body)
