"""``/healthz`` (the process is up) and ``/readyz`` (broker, job store, storage reachable)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse

from service.api.deps import SettingsDep, StorageDep, StoreDep, TaskClientDep
from service.schemas import Health, Readiness

router = APIRouter(tags=["health"])


@router.get("/healthz", operation_id="healthz")
async def healthz() -> Health:
    """The API process answers."""
    return Health(status="ok")


@router.get(
    "/readyz",
    operation_id="readyz",
    response_model=Readiness,
    responses={503: {"model": Readiness, "description": "a dependency is unreachable"}},
)
async def readyz(
    settings: SettingsDep, store: StoreDep, storage: StorageDep, tasks: TaskClientDep
) -> JSONResponse:
    """Broker, job store and artifact storage are reachable."""
    checks = {
        "job_store": await run_in_threadpool(store.ping),
        "storage": await run_in_threadpool(storage.ping),
        "broker": await run_in_threadpool(tasks.ping),
    }
    ok = all(checks.values())
    body = Readiness(
        status="ready" if ok else "not_ready", checks=checks, embedded=settings.is_embedded
    )
    return JSONResponse(body.model_dump(), status_code=200 if ok else 503)
