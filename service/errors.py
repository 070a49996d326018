"""JSON errors: every error body is ``{"error": {"type", "message", "field"}}``."""

from __future__ import annotations

import logging
import re
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from conformorph.worker.storage import StorageUnavailable

log = logging.getLogger(__name__)


class ApiError(Exception):
    """An error answered to the client with ``status`` and a JSON body."""

    def __init__(
        self,
        status: int,
        type_: str,
        message: str,
        field: str | None = None,
        headers: dict[str, str] | None = None,
    ) -> None:
        super().__init__(message)
        self.status, self.type, self.message, self.field = status, type_, message, field
        self.headers = headers


class BodyTooLarge(StarletteHTTPException):
    """A request body over its limit (413). An HTTPException, so that FastAPI's body
    parsing passes it on to the handler instead of answering 400."""

    def __init__(self, limit: int, field: str | None = None) -> None:
        what = "upload" if field == "file" else "request body"
        super().__init__(413, f"the {what} exceeds the limit of {limit} bytes")
        self.limit, self.field = limit, field


def error_json(
    status: int, type_: str, message: str, field: str | None = None, **kw: Any
) -> JSONResponse:
    return JSONResponse(
        {"error": {"type": type_, "message": message, "field": field}}, status_code=status, **kw
    )


_HTTP_TYPES = {
    400: "bad_request",
    401: "unauthorized",
    403: "forbidden",
    404: "not_found",
    405: "method_not_allowed",
    406: "not_acceptable",
    409: "conflict",
    413: "payload_too_large",
    415: "unsupported_media_type",
    416: "range_not_satisfiable",
    422: "validation_error",
    429: "too_many_requests",
}


def _field_of(loc: tuple[Any, ...] | list[Any]) -> str | None:
    parts = [str(p) for p in loc if p not in ("body", "query", "path", "header")]
    if not parts:
        return None
    out = parts[0]
    for p in parts[1:]:
        out += f"[{p}]" if p.isdigit() else f".{p}"
    return out


def _allowed_methods(request: Request) -> list[str]:
    """Every method the API documents for this path (Starlette lists only one route's)."""
    table: list[tuple[re.Pattern[str], set[str]]] | None = getattr(
        request.app.state, "allow_table", None
    )
    if table is None:
        table = []
        for template, item in request.app.openapi().get("paths", {}).items():
            parts = re.split(r"(\{[^}]+\})", template)
            rx = "".join(
                ("(.+)" if p == "{name}" else "([^/]+)") if p.startswith("{") else re.escape(p)
                for p in parts
            )
            table.append((re.compile(f"^{rx}$"), {m.upper() for m in item}))
        request.app.state.allow_table = table
    methods: set[str] = set()
    for pattern, ms in table:
        if pattern.match(request.url.path):
            methods |= ms
    return sorted(methods)


def install_error_handlers(app: FastAPI) -> None:
    """Map every error to the JSON body; nothing escapes as an HTML 500."""

    @app.exception_handler(ApiError)
    async def _api_error(_: Request, exc: ApiError) -> JSONResponse:
        return error_json(exc.status, exc.type, exc.message, exc.field, headers=exc.headers)

    @app.exception_handler(StorageUnavailable)
    async def _storage_unavailable(_: Request, exc: StorageUnavailable) -> JSONResponse:
        log.warning("object store unavailable: %s", exc)
        return error_json(
            503,
            "storage_unavailable",
            "the artifact store cannot be reached; nothing was changed, try again later",
            headers={"Retry-After": str(exc.retry_after)},
        )

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        errs = exc.errors()
        first = errs[0] if errs else {}
        msg = "; ".join(
            f"{_field_of(e.get('loc', ())) or 'request'}: {e.get('msg', 'invalid')}"
            for e in errs[:5]
        )
        return error_json(
            422, "validation_error", msg or "invalid request", _field_of(first.get("loc", ()))
        )

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        detail = exc.detail if isinstance(exc.detail, str) else "error"
        headers = dict(getattr(exc, "headers", None) or {})
        if exc.status_code == 405:
            headers["Allow"] = ", ".join(_allowed_methods(request))
        return error_json(
            exc.status_code,
            _HTTP_TYPES.get(exc.status_code, "http_error"),
            detail,
            getattr(exc, "field", None),
            headers=headers or None,
        )

    @app.exception_handler(Exception)
    async def _unexpected(_: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error")
        return error_json(500, "internal_error", "internal error; see the server log")
