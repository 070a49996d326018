"""``POST /v1/reconstructions``: map, (H, λ), Algorithm 1 reconstruction, as a job."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Header, Response
from fastapi.concurrency import run_in_threadpool

from service.api.deps import OwnerDep, SettingsDep, StoreDep, TaskClientDep
from service.api.submit import SUBMIT_ERRORS, mesh_param, require_mesh, submit_job
from service.schemas import JobPublic, ReconstructionCreate
from worker import names

router = APIRouter(prefix="/v1/reconstructions", tags=["reconstructions"])


@router.post(
    "",
    operation_id="create_reconstruction",
    status_code=202,
    responses={
        200: {"model": JobPublic, "description": "same Idempotency-Key: the existing job"},
        **SUBMIT_ERRORS,
    },
)
async def create_reconstruction(
    body: ReconstructionCreate,
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    tasks: TaskClientDep,
    response: Response,
    idempotency_key: Annotated[str | None, Header(alias="Idempotency-Key")] = None,
) -> JobPublic:
    """Start a job: disk map, mean curvature and conformal factor, then the surface rebuilt
    from them alone (``reconstruction.obj`` in the input's vertex order, ``errors.json``)."""
    mesh = await run_in_threadpool(require_mesh, store, owner, body.mesh, "mesh")
    # like ``conformorph reconstruct``: the map's folds are reported, not repaired,
    # since reconstruction needs no bijective map
    params = {
        "mesh": mesh_param(mesh),
        "method": body.method,
        "curvature": body.curvature,
        "fold_policy": "report",
    }
    return await submit_job(
        kind=names.KIND_RECONSTRUCTION,
        params=params,
        owner=owner,
        idempotency_key=idempotency_key,
        store=store,
        tasks=tasks,
        settings=settings,
        response=response,
    )
