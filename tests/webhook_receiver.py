"""A real HTTP server on 127.0.0.1 that receives webhooks in tests.

It answers each POST with the next status of ``script`` (then ``default``), and
records every request (path, headers, raw body). A 3xx answer carries a
``Location`` to ``/redirected`` on the same server, so a test can see that
redirects are not followed. With ``trickle`` it sends its answer one byte every
``trickle`` seconds (a slow receiver holding a delivery open).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer


@dataclass(frozen=True)
class Received:
    path: str
    headers: dict[str, str]
    body: bytes
    at: float


class Receiver:
    """The server's state: what it answers and what it got."""

    def __init__(
        self, script: list[int] | None = None, default: int = 200, trickle: float | None = None
    ) -> None:
        self.script, self.default, self.trickle = list(script or []), default, trickle
        self.requests: list[Received] = []
        self.lock = threading.Lock()
        self.port = 0

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/hook"

    def next_status(self) -> int:
        with self.lock:
            return self.script.pop(0) if self.script else self.default

    def wait_for(self, n: int, timeout: float = 60.0) -> list[Received]:
        """The first ``n`` requests once they arrived (AssertionError after ``timeout``)."""
        deadline = time.monotonic() + timeout
        while len(self.requests) < n:
            assert time.monotonic() < deadline, f"{len(self.requests)} of {n} webhook(s) came"
            time.sleep(0.05)
        return self.requests[:n]


def _handler(receiver: Receiver) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        def do_POST(self) -> None:  # noqa: N802 - the http.server API
            body = self.rfile.read(int(self.headers.get("Content-Length") or 0))
            with receiver.lock:
                receiver.requests.append(
                    Received(self.path, dict(self.headers.items()), body, time.time())
                )
            status = receiver.next_status() if self.path == "/hook" else 200
            if receiver.trickle is not None:
                self._trickle(status, receiver.trickle)
                return
            self.send_response(status)
            if 300 <= status < 400:
                self.send_header("Location", f"http://127.0.0.1:{receiver.port}/redirected")
            self.send_header("Content-Length", "0")
            self.end_headers()

        def _trickle(self, status: int, pause: float) -> None:
            answer = f"HTTP/1.1 {status} OK\r\nContent-Length: 0\r\n\r\n".encode()
            try:
                for k in range(len(answer)):
                    self.wfile.write(answer[k : k + 1])
                    self.wfile.flush()
                    time.sleep(pause)
            except OSError:  # the sender gave up
                pass
            self.close_connection = True

        def log_message(self, *args: object) -> None:
            pass

    return Handler


@contextmanager
def webhook_receiver(
    script: list[int] | None = None, default: int = 200, trickle: float | None = None
) -> Iterator[Receiver]:
    """A running receiver (see the module docstring), stopped at the end."""
    receiver = Receiver(script, default, trickle)
    server = ThreadingHTTPServer(("127.0.0.1", 0), _handler(receiver))
    receiver.port = int(server.server_address[1])
    thread = threading.Thread(target=server.serve_forever, daemon=True, name="webhook-receiver")
    thread.start()
    try:
        yield receiver
    finally:
        server.shutdown()
        server.server_close()
