"""One HTTP request under a total wall-clock deadline (connect, TLS, send and answer together).

httpx's timeouts bound each socket operation, not the request: a receiver that
sends one byte every 3 s never trips a 5 s read timeout, and held one webhook
attempt for 201 s (issue 30). Here every socket operation is given at most the
time left until the request's deadline (httpcore's network backend, wrapped),
so the request ends by the deadline whatever the peer does.
"""

from __future__ import annotations

import ssl
import time
from collections.abc import Iterable
from typing import Any

import httpcore

#: seconds one socket operation may wait when the deadline is further away
OPERATION_TIMEOUT = 10.0


class DeadlineExceeded(httpcore.TimeoutException):
    """The request's total deadline passed."""


class _DeadlineStream(httpcore.NetworkStream):
    """A network stream whose every operation ends by ``deadline`` (monotonic seconds)."""

    def __init__(self, stream: httpcore.NetworkStream, deadline: float) -> None:
        self._stream, self._deadline = stream, deadline

    def _left(self, timeout: float | None) -> float:
        left = self._deadline - time.monotonic()
        if left <= 0:
            raise DeadlineExceeded("the request's total deadline passed")
        return left if timeout is None else min(timeout, left)

    def read(self, max_bytes: int, timeout: float | None = None) -> bytes:
        return self._stream.read(max_bytes, self._left(timeout))

    def write(self, buffer: bytes, timeout: float | None = None) -> None:
        # a peer that reads slowly is bounded too: sendall's timeout is per call
        self._stream.write(buffer, self._left(timeout))

    def close(self) -> None:
        self._stream.close()

    def start_tls(
        self,
        ssl_context: ssl.SSLContext,
        server_hostname: str | None = None,
        timeout: float | None = None,
    ) -> httpcore.NetworkStream:
        inner = self._stream.start_tls(ssl_context, server_hostname, self._left(timeout))
        return _DeadlineStream(inner, self._deadline)

    def get_extra_info(self, info: str) -> Any:
        return self._stream.get_extra_info(info)


class _DeadlineBackend(httpcore.NetworkBackend):
    """httpcore's synchronous backend with :class:`_DeadlineStream` connections."""

    def __init__(self, deadline: float) -> None:
        self._backend, self._deadline = httpcore.SyncBackend(), deadline

    def connect_tcp(
        self,
        host: str,
        port: int,
        timeout: float | None = None,
        local_address: str | None = None,
        socket_options: Iterable[Any] | None = None,
    ) -> httpcore.NetworkStream:
        left = self._deadline - time.monotonic()
        if left <= 0:
            raise DeadlineExceeded("the request's total deadline passed")
        stream = self._backend.connect_tcp(
            host,
            port,
            left if timeout is None else min(timeout, left),
            local_address,
            socket_options,
        )
        return _DeadlineStream(stream, self._deadline)

    def sleep(self, seconds: float) -> None:
        time.sleep(max(0.0, min(seconds, self._deadline - time.monotonic())))


def post_status(
    url: str,
    body: bytes,
    headers: dict[str, str],
    *,
    deadline_seconds: float,
    sni_hostname: str | None = None,
) -> int:
    """POST ``body`` to ``url`` and answer the response's status, all within ``deadline_seconds``.

    Parameters
    ----------
    url : str
        An ``http`` or ``https`` URL (the host may be an address literal).
    body : bytes
    headers : dict
        Request headers (``Host`` among them when ``url`` names an address).
    deadline_seconds : float
        Total wall-clock seconds for connecting, TLS, sending and reading the
        status line and headers. The response body is not read.
    sni_hostname : str, optional
        The name TLS sends and verifies the certificate against (a URL naming
        an address literal).

    Returns
    -------
    int
        The HTTP status. Redirects are not followed.

    Raises
    ------
    httpcore.TimeoutException
        The deadline (:class:`DeadlineExceeded`) or an operation's timeout passed.
    httpcore.NetworkError, httpcore.ProtocolError, httpcore.UnsupportedProtocol
        The connection failed or the answer is not HTTP.
    """
    deadline = time.monotonic() + float(deadline_seconds)
    op = min(OPERATION_TIMEOUT, float(deadline_seconds))
    extensions: dict[str, Any] = {"timeout": {"connect": op, "read": op, "write": op, "pool": op}}
    if sni_hostname:
        extensions["sni_hostname"] = sni_hostname
    try:
        return _post(url, body, headers, deadline, extensions)
    except httpcore.TimeoutException as exc:
        if time.monotonic() < deadline:
            raise
        raise DeadlineExceeded(
            f"no complete answer within the attempt's deadline of {deadline_seconds:g} s"
        ) from exc


def _post(
    url: str, body: bytes, headers: dict[str, str], deadline: float, extensions: dict[str, Any]
) -> int:
    with (
        httpcore.ConnectionPool(
            ssl_context=ssl.create_default_context(),
            network_backend=_DeadlineBackend(deadline),
            max_connections=1,
            retries=0,
        ) as pool,
        pool.stream(
            "POST", url, headers=list(headers.items()), content=body, extensions=extensions
        ) as response,
    ):
        return int(response.status)
