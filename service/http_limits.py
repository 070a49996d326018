"""Limits on a request's head (request line and headers), for ``conformorph serve``.

uvicorn's default HTTP parser (httptools) has no limit on a header's size: a
64 MB header on ``/healthz`` was read whole and answered 200. ``conformorph
serve`` runs uvicorn's h11 protocol instead, with h11's limit on an incomplete
event (the whole head must arrive within ``MAX_HEAD_BYTES``), and
:class:`LimitedH11Protocol` answers a head over it with 431 and a JSON body,
and any other malformed request with a JSON 400, then closes the connection.

h11 enforces its limit only while a head is incomplete: a 70 KB head that
arrives in one read was parsed whole and served (and a 100 KB ``Range`` header
was answered 206 on GET, 431 on HEAD, as the reads happened to fall).
:class:`HeadLimitMiddleware` counts every parsed head against the same limit, so
a head over it is 431 however it arrived, on every method and behind any ASGI
server. Behind another server, configure its own limits too (uvicorn:
``--http h11 --h11-max-incomplete-event-size 65536``), so that a huge head is not
buffered first.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from starlette.types import ASGIApp, Receive, Scope, Send
from uvicorn.protocols.http.h11_impl import H11Protocol

#: the largest request line plus headers accepted, in bytes (431 beyond)
MAX_HEAD_BYTES = 64 * 1024


class LimitedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol whose refusals are JSON: 431 for a head over the limit."""

    def send_400_response(self, msg: str) -> None:
        buffered = len(self.conn.trailing_data[0])
        limit = self.conn._max_incomplete_event_size  # noqa: SLF001 - h11 has no getter
        if buffered > limit:
            status, type_ = 431, "request_header_too_large"
            message = f"the request line and headers exceed the limit of {limit} bytes"
        else:
            status, type_, message = 400, "bad_request", "malformed HTTP request"
        body = json.dumps({"error": {"type": type_, "message": message, "field": None}}).encode()
        headers = [
            (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode()),
            (b"connection", b"close"),
        ]
        try:
            # the connection is in h11's ERROR state: write the answer by hand
            head = f"HTTP/1.1 {status} {_REASONS[status]}\r\n".encode()
            head += b"".join(k + b": " + v + b"\r\n" for k, v in headers) + b"\r\n"
            self.transport.write(head + body)
        finally:
            self.transport.close()


_REASONS = {400: "Bad Request", 431: "Request Header Fields Too Large"}


def head_bytes(scope: Mapping[str, Any]) -> int:
    """The size of an HTTP/1.1 request's head as sent: request line and header lines.

    Parameters
    ----------
    scope : dict
        An ASGI ``http`` scope.

    Returns
    -------
    int
        ``METHOD SP target SP HTTP/1.1 CRLF``, each ``name: value CRLF``, the final CRLF.
    """
    target = len(scope.get("raw_path") or scope.get("path", "").encode())
    query = scope.get("query_string", b"")
    target += 1 + len(query) if query else 0
    line = len(scope.get("method", "")) + 1 + target + 1 + len("HTTP/1.1") + 2
    return line + sum(len(k) + 2 + len(v) + 2 for k, v in scope.get("headers", [])) + 2


class HeadLimitMiddleware:
    """Answer 431 (JSON) to any request whose head exceeds ``limit`` bytes, whatever the
    method and however the server read it (see the module docstring)."""

    def __init__(self, app: ASGIApp, *, limit: int = MAX_HEAD_BYTES) -> None:
        self.app, self.limit = app, limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or head_bytes(scope) <= self.limit:
            await self.app(scope, receive, send)
            return
        body = json.dumps(
            {
                "error": {
                    "type": "request_header_too_large",
                    "message": "the request line and headers exceed the limit of "
                    f"{self.limit} bytes",
                    "field": None,
                }
            }
        ).encode()
        await send(
            {
                "type": "http.response.start",
                "status": 431,
                "headers": [
                    (b"content-type", b"application/json"),
                    (b"content-length", str(len(body)).encode()),
                    (b"connection", b"close"),
                ],
            }
        )
        await send(
            {"type": "http.response.body", "body": b"" if scope["method"] == "HEAD" else body}
        )
