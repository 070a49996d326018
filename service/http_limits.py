"""Limits on a request's head (request line and headers), for ``conformorph serve``.

uvicorn's default HTTP parser (httptools) has no limit on a header's size: a
64 MB header on ``/healthz`` was read whole and answered 200. ``conformorph
serve`` runs uvicorn's h11 protocol instead, with h11's limit on an incomplete
event (the whole head must arrive within ``MAX_HEAD_BYTES``), and
:class:`LimitedH11Protocol` answers a head over it with 431 and a JSON body,
and any other malformed request with a JSON 400, then closes the connection.

Behind another ASGI server, configure its own limits (uvicorn:
``--http h11 --h11-max-incomplete-event-size 65536``).
"""

from __future__ import annotations

import json

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
