"""``/healthz`` (the process is up) and ``/readyz`` (broker, job store, storage reachable)."""

from __future__ import annotations

import asyncio

from fastapi import APIRouter
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse

from conformorph.service.api.deps import SettingsDep, StorageDep, StoreDep, TaskClientDep
from conformorph.service.schemas import Health, Readiness

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
    """Broker, job store and artifact storage are reachable, and a worker serves
    upload validations."""
    # at once: each is bounded, and readiness answers within the slowest
    found = await asyncio.gather(
        run_in_threadpool(store.ping),
        run_in_threadpool(storage.ping),
        tasks.ping(),
        # a worker consumes the upload-validation queue and keeps up with it
        tasks.validation_served(),
    )
    checks = dict(zip(("job_store", "storage", "broker", "validation_workers"), found, strict=True))
    ok = all(checks.values())
    body = Readiness(
        status="ready" if ok else "not_ready", checks=checks, embedded=settings.is_embedded
    )
    return JSONResponse(body.model_dump(), status_code=200 if ok else 503)
