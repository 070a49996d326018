"""The FastAPI application: ``create_app(settings)`` builds it with its dependencies.

Run it with ``conformorph serve`` (API plus an embedded worker) or any ASGI
server: ``uvicorn --factory service.main:create_app``.
"""

from __future__ import annotations

import json
from typing import Any

from fastapi import FastAPI
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.api.deps import KeyCache
from service.api.routes import (
    conformal_maps,
    health,
    jobs,
    landmarks,
    meshes,
    morphs,
    reconstructions,
    shapes,
    textures,
)
from service.core.config import Settings, get_settings
from service.errors import install_error_handlers
from service.schemas import ErrorBody
from service.task_client import CeleryTaskClient, TaskClient
from service.viewer import install_viewer
from worker.job_store import JobStore
from worker.storage import LocalStorage, Storage

OPENAPI_TAGS = [
    {"name": "meshes", "description": "Upload meshes (validated before they are kept)."},
    {"name": "textures", "description": "Upload PNG/JPEG textures for morphs."},
    {"name": "conformal maps", "description": "Disk conformal maps of a mesh, as jobs."},
    {
        "name": "reconstructions",
        "description": "Surfaces rebuilt from (H, λ) on the disk, as jobs.",
    },
    {"name": "landmarks", "description": "Landmark documents for face morphs (any shared layout)."},
    {"name": "shapes", "description": "Upload 2D shapes (JSON rings or SVG) for 2D morphs."},
    {"name": "morphs", "description": "Face morphs and 2D strain-field morphs, as jobs."},
    {"name": "jobs", "description": "Job state, events, cancellation and artifacts."},
    {"name": "health", "description": "Liveness and readiness."},
]

#: multipart framing allowed on top of the file itself
_MULTIPART_OVERHEAD = 64 * 1024


class BodyLimitMiddleware:
    """Answer 413 as soon as an upload's body is larger than the limit.

    Checks ``Content-Length`` up front and counts the bytes of bodies sent
    without one, so a large upload is refused before it is buffered
    (Kludex/starlette #579).
    """

    def __init__(self, app: ASGIApp, limits: dict[str, int]) -> None:
        self.app, self.limits = app, limits

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope.get("method") != "POST":
            await self.app(scope, receive, send)
            return
        limit = self.limits.get(scope.get("path", "").rstrip("/"))
        if limit is None:
            await self.app(scope, receive, send)
            return
        limit += _MULTIPART_OVERHEAD
        for k, v in scope.get("headers", []):
            if k == b"content-length" and v.isdigit() and int(v) > limit:
                await _send_413(send, limit)
                return
        seen = 0
        started = False

        async def counting_receive() -> Message:
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > limit:
                    raise _TooLarge()
            return msg

        async def tracking_send(msg: Message) -> None:
            nonlocal started
            if msg["type"] == "http.response.start":
                started = True
            await send(msg)

        try:
            await self.app(scope, counting_receive, tracking_send)
        except _TooLarge:
            if not started:
                await _send_413(send, limit)


class _TooLarge(Exception):
    pass


async def _send_413(send: Send, limit: int) -> None:
    body = json.dumps(
        {
            "error": {
                "type": "payload_too_large",
                "message": f"request body exceeds the upload limit ({limit - _MULTIPART_OVERHEAD} bytes)",
                "field": "file",
            }
        }
    ).encode()
    await send(
        {
            "type": "http.response.start",
            "status": 413,
            "headers": [
                (b"content-type", b"application/json"),
                (b"content-length", str(len(body)).encode()),
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})


def create_app(
    settings: Settings | None = None,
    *,
    store: JobStore | None = None,
    storage: Storage | None = None,
    task_client: TaskClient | None = None,
) -> FastAPI:
    """Build the API. Anything not given is made from ``settings``."""
    settings = settings or get_settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    app = FastAPI(
        title="conformorph",
        version="0.1.0",
        summary="Conformal face morphing as a service",
        description=(
            "Upload meshes, start disk conformal maps, reconstructions and morphs as jobs, "
            "follow them, and fetch their artifacts. Errors are JSON: "
            '`{"error": {"type", "message", "field"}}`.'
        ),
        openapi_tags=OPENAPI_TAGS,
        responses={
            400: {"model": ErrorBody, "description": "malformed request (e.g. an unparsable body)"}
        },
    )
    app.state.settings = settings
    app.state.store = store or JobStore(settings.resolved_database_url)
    app.state.storage = storage or LocalStorage(settings.resolved_storage_dir)
    app.state.task_client = task_client or CeleryTaskClient(settings)
    app.state.key_cache = KeyCache(app.state.store, open_ttl=settings.open_mode_recheck_seconds)
    install_error_handlers(app)
    for module in (
        health,
        meshes,
        textures,
        landmarks,
        shapes,
        conformal_maps,
        reconstructions,
        morphs,
        jobs,
    ):
        app.include_router(module.router)
    install_viewer(app)  # the browser viewer at / (built assets in service/static)
    app.add_middleware(
        BodyLimitMiddleware,
        limits={
            "/v1/meshes": settings.max_upload_bytes,
            "/v1/textures": settings.max_texture_bytes,
        },
    )
    return app


def openapi_document(app: FastAPI | None = None) -> dict[str, Any]:
    """The OpenAPI document (what ``conformorph openapi`` writes)."""
    return (app or create_app()).openapi()
