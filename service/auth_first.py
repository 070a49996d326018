"""Authentication before the body: a request without a valid key costs no body read.

FastAPI parses a route's body (multipart spooling, JSON) before it solves the
route's dependencies, so the owner dependency alone would answer 401 only after
a 60 MB upload had been read and written to disk. :class:`AuthFirst` checks the
key from the headers as the request arrives, answers 401/403 without calling
``receive`` at all, and hands the caller on in ``scope["state"]["owner"]``
(read by :func:`conformorph.service.api.deps.get_owner`).
"""

from __future__ import annotations

import json

from starlette.types import ASGIApp, Receive, Scope, Send

from conformorph.service.api.deps import KeyCache, authenticate
from conformorph.service.errors import ApiError

#: paths whose every route needs the caller (all of the API; not health or the viewer)
PROTECTED_PREFIX = "/v1/"


class AuthFirst:
    """ASGI middleware: authenticate ``/v1/`` requests from their headers, first."""

    def __init__(self, app: ASGIApp, *, keys: KeyCache) -> None:
        self.app, self.keys = app, keys

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not str(scope.get("path", "")).startswith(PROTECTED_PREFIX):
            await self.app(scope, receive, send)
            return
        auth = ""
        for k, v in scope.get("headers", []):
            if k == b"authorization":
                auth = v.decode("latin-1")
                break
        client = scope.get("client") or ("", 0)
        try:
            owner = await authenticate(auth, str(client[0]), self.keys)
        except ApiError as exc:
            await _send_error(send, exc)
            return
        scope.setdefault("state", {})["owner"] = owner
        await self.app(scope, receive, send)


async def _send_error(send: Send, exc: ApiError) -> None:
    body = json.dumps(
        {"error": {"type": exc.type, "message": exc.message, "field": exc.field}}
    ).encode()
    headers = [
        (b"content-type", b"application/json"),
        (b"content-length", str(len(body)).encode()),
        # the body was not read: the connection cannot be reused for another request
        (b"connection", b"close"),
    ]
    headers += [(k.lower().encode(), v.encode()) for k, v in (exc.headers or {}).items()]
    await send({"type": "http.response.start", "status": exc.status, "headers": headers})
    await send({"type": "http.response.body", "body": body})
