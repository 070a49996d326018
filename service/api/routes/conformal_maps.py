"""``POST /v1/conformal-maps``: a disk conformal map of an uploaded mesh, as a job."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Header, Response
from fastapi.concurrency import run_in_threadpool

from service.api.deps import OwnerDep, SettingsDep, StoreDep, TaskClientDep
from service.api.submit import SUBMIT_ERRORS, check_vertex, mesh_param, require_mesh, submit_job
from service.schemas import ConformalMapCreate, JobPublic
from worker import names

router = APIRouter(prefix="/v1/conformal-maps", tags=["conformal maps"])


@router.post(
    "",
    operation_id="create_conformal_map",
    status_code=202,
    responses={
        200: {"model": JobPublic, "description": "same Idempotency-Key: the existing job"},
        **SUBMIT_ERRORS,
    },
)
async def create_conformal_map(
    body: ConformalMapCreate,
    owner: OwnerDep,
    settings: SettingsDep,
    store: StoreDep,
    tasks: TaskClientDep,
    response: Response,
    idempotency_key: Annotated[str | None, Header(alias="Idempotency-Key")] = None,
) -> JobPublic:
    """Start a job computing the disk map (``disk_map.npz``: uv, faces) and ``quality.json``."""
    mesh = await run_in_threadpool(require_mesh, store, owner, body.mesh, "mesh")
    check_vertex(mesh, body.center_vertex, "center_vertex")
    check_vertex(mesh, body.angle_vertex, "angle_vertex")
    params = {
        "mesh": mesh_param(mesh),
        "method": body.method,
        "center_vertex": body.center_vertex,
        "angle_vertex": body.angle_vertex,
    }
    return await submit_job(
        kind=names.KIND_CONFORMAL_MAP,
        params=params,
        owner=owner,
        idempotency_key=idempotency_key,
        store=store,
        tasks=tasks,
        settings=settings,
        response=response,
    )
