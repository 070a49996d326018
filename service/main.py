"""The FastAPI application: ``create_app(settings)`` builds it with its dependencies.

Run it with ``conformorph serve`` (API plus an embedded worker) or any ASGI
server: ``uvicorn --factory conformorph.service.main:create_app``.
"""

from __future__ import annotations

import json
from typing import Any

from fastapi import FastAPI
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from conformorph.service.api.deps import KeyCache
from conformorph.service.api.routes import (
    conformal_maps,
    health,
    jobs,
    landmark_detections,
    landmarks,
    meshes,
    morphs,
    reconstructions,
    shapes,
    textures,
)
from conformorph.service.auth_first import AuthFirst
from conformorph.service.core.config import Settings, get_settings
from conformorph.service.errors import BodyTooLarge, install_error_handlers
from conformorph.service.http_limits import HeadLimitMiddleware
from conformorph.service.metrics import (
    MetricsMiddleware,
    QueueDepths,
    ServiceMetrics,
    broker_queue_depths,
)
from conformorph.service.schemas import ErrorBody
from conformorph.service.task_client import AsyncTasks, CeleryTaskClient, TaskClient
from conformorph.service.viewer import install_viewer
from conformorph.worker import names
from conformorph.worker.job_store import JobStore
from conformorph.worker.open_storage import open_storage
from conformorph.worker.storage import Storage

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
#: methods whose bodies are limited (the API reads no other method's body)
_BODY_METHODS = frozenset({"POST", "PUT", "PATCH"})


class BodyLimitMiddleware:
    """Answer 413 as soon as a request body is larger than its limit.

    Every POST has a limit: the routes in ``uploads`` (multipart uploads: the
    file's limit plus room for the framing, reported on field ``file``), those
    in ``limits`` (JSON bodies with their own limit), and any other path
    ``default``. Checks ``Content-Length`` up front and counts the bytes of
    bodies sent without one, so a large body is refused before it is buffered
    (Kludex/starlette #579).
    """

    def __init__(
        self, app: ASGIApp, *, uploads: dict[str, int], limits: dict[str, int], default: int
    ) -> None:
        self.app, self.uploads, self.limits, self.default = app, uploads, limits, default

    def _limit(self, path: str) -> tuple[int, int, str | None]:
        """(bytes allowed, the limit as configured, field) for a request path."""
        path = path.rstrip("/")
        if path in self.uploads:
            return self.uploads[path] + _MULTIPART_OVERHEAD, self.uploads[path], "file"
        limit = self.limits.get(path, self.default)
        return limit, limit, None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope.get("method") not in _BODY_METHODS:
            await self.app(scope, receive, send)
            return
        allowed, limit, field = self._limit(scope.get("path", ""))
        too_large = BodyTooLarge(limit, field)
        for k, v in scope.get("headers", []):
            if k == b"content-length" and v.isdigit() and int(v) > allowed:
                await _send_413(send, too_large)
                return
        seen = 0
        started = False

        async def counting_receive() -> Message:
            nonlocal seen
            msg = await receive()
            if msg["type"] == "http.request":
                seen += len(msg.get("body", b""))
                if seen > allowed:
                    # an HTTPException: FastAPI's body parsing passes it on (anything
                    # else it turns into a 400), and the app's handler answers 413
                    raise too_large
            return msg

        async def tracking_send(msg: Message) -> None:
            nonlocal started
            if msg["type"] == "http.response.start":
                started = True
            await send(msg)

        try:
            await self.app(scope, counting_receive, tracking_send)
        except BodyTooLarge as exc:
            if not started:
                await _send_413(send, exc)


async def _send_413(send: Send, exc: BodyTooLarge) -> None:
    body = json.dumps(
        {"error": {"type": "payload_too_large", "message": exc.detail, "field": exc.field}}
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
    app.state.storage = storage or open_storage(settings)
    app.state.task_client = task_client or CeleryTaskClient(
        settings, broker_timeout=settings.broker_timeout
    )
    app.state.tasks = AsyncTasks(
        app.state.task_client,
        validate_timeout=settings.validate_timeout,
        broker_timeout=settings.broker_timeout,
        validation_threads=settings.validation_threads,
        validation_slots=settings.validation_slots,
    )
    app.state.key_cache = KeyCache(app.state.store, open_ttl=settings.open_mode_recheck_seconds)
    install_error_handlers(app)
    for module in (
        health,
        meshes,
        textures,
        landmarks,
        landmark_detections,
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
        uploads={
            "/v1/meshes": settings.max_upload_bytes,
            "/v1/shapes": settings.max_upload_bytes,
            "/v1/textures": settings.max_texture_bytes,
        },
        # a morph's inline landmarks are a landmark document too
        limits={
            "/v1/landmarks": settings.max_landmark_bytes,
            "/v1/morphs": settings.max_landmark_bytes,
        },
        default=settings.max_json_bytes,
    )
    # the caller is known before any body limit is counted or body read
    app.add_middleware(AuthFirst, keys=app.state.key_cache)
    # a head over the limit is refused before the key is looked up (431 on every method)
    app.add_middleware(HeadLimitMiddleware)
    if settings.metrics_enabled:  # outermost: /metrics needs no key, every answer is timed
        app.state.metrics = ServiceMetrics(app.state.store, _queue_depths(settings, app))
        app.add_middleware(MetricsMiddleware, metrics=app.state.metrics, fastapi_app=app)
    return app


def _queue_depths(settings: Settings, app: FastAPI) -> QueueDepths | None:
    """Queue depths from the broker behind the real Celery client (not the embedded one)."""
    client = app.state.task_client
    if settings.is_embedded or not isinstance(client, CeleryTaskClient):
        return None
    queues = (names.QUEUE_JOBS, names.QUEUE_INTERACTIVE, names.QUEUE_WEBHOOKS)
    return lambda: broker_queue_depths(client.app, queues)


def openapi_document(app: FastAPI | None = None) -> dict[str, Any]:
    """The OpenAPI document (what ``conformorph openapi`` writes)."""
    return (app or create_app()).openapi()
