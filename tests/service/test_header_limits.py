"""Issue 15 item 9: ``conformorph serve`` limits a request's head (request line and
headers): past the limit it answers 431 with a JSON body and closes, at once and
without holding the header in memory. Against a real started server."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    port = _free_port()
    data = tmp_path_factory.mktemp("serve")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "CONFORMORPH_DATA_DIR": str(data)}
    env.pop("CONFORMORPH_BROKER_URL", None)
    proc = subprocess.Popen(
        [sys.executable, "-m", "conformorph.cli", "serve", "--port", str(port), "--workers", "0"],
        env=env,
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                if httpx.get(f"{base}/healthz", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                time.sleep(0.2)
        else:
            pytest.fail("conformorph serve did not start")
        yield base
    finally:
        proc.terminate()
        proc.wait(30)


def _raw(base: str, head: bytes) -> bytes:
    """Send ``head`` (as fast as the server takes it) and read the answer until close."""
    host, port = base.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=20) as s:
        try:
            s.sendall(head)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the server stopped reading: fine, its answer is what counts
        out = b""
        try:
            while chunk := s.recv(65536):
                out += chunk
        except (ConnectionResetError, TimeoutError):
            pass
    return out


@pytest.mark.parametrize(
    "head",
    [
        b"GET /healthz HTTP/1.1\r\nHost: x\r\nX-Big: " + b"a" * (8 << 20) + b"\r\n\r\n",
        b"GET /healthz?" + b"q" * (1 << 20) + b" HTTP/1.1\r\nHost: x\r\n\r\n",
        b"GET /healthz HTTP/1.1\r\nHost: x\r\n" + b"X-A: b\r\n" * 100_000 + b"\r\n",
    ],
    ids=["one-long-header", "long-request-line", "many-headers"],
)
def test_a_request_head_over_the_limit_is_431(served: str, head: bytes) -> None:
    t0 = time.monotonic()
    answer = _raw(served, head)
    assert time.monotonic() - t0 < 10
    status_line, _, rest = answer.partition(b"\r\n")
    assert status_line.startswith(b"HTTP/1.1 431"), answer[:200]
    body = json.loads(rest.split(b"\r\n\r\n", 1)[1])
    assert body["error"]["type"] == "request_header_too_large"
    # and the server is still well
    assert httpx.get(f"{served}/healthz", timeout=5).status_code == 200


def test_a_head_within_the_limit_is_served(served: str) -> None:
    r = httpx.get(f"{served}/healthz", headers={"X-Big": "a" * 32_000}, timeout=5)
    assert r.status_code == 200


def test_a_malformed_request_is_a_json_400(served: str) -> None:
    answer = _raw(served, b"GET /healthz HTTP/1.1\r\nHost x\r\n\r\n")
    assert answer.startswith(b"HTTP/1.1 400"), answer[:200]
    body = json.loads(answer.split(b"\r\n\r\n", 1)[1])
    assert body["error"]["type"] == "bad_request"


# issue 30, item 11: h11 limits only an incomplete head; a head over the limit that
# arrives whole must be refused too, the same on every method


@pytest.mark.parametrize("method", ["GET", "HEAD"])
def test_a_whole_head_over_the_limit_is_431_on_every_method(served: str, method: str) -> None:
    for name, value in (("X-Big", "a" * 70_000), ("Range", "bytes=0-1," + "2-3," * 25_000)):
        head = f"{method} /healthz HTTP/1.1\r\nHost: x\r\n{name}: {value}\r\n\r\n".encode()
        answer = _raw(served, head)
        assert answer.startswith(b"HTTP/1.1 431"), (method, name, answer[:200])
    assert httpx.get(f"{served}/healthz", timeout=5).status_code == 200


def test_head_limit_middleware_in_process(tmp_path: Path) -> None:
    from fastapi.testclient import TestClient

    from conformorph.service.core.config import Settings
    from conformorph.service.http_limits import MAX_HEAD_BYTES, head_bytes
    from conformorph.service.main import create_app

    scope = {"method": "GET", "raw_path": b"/a", "query_string": b"b=1", "headers": [(b"h", b"v")]}
    assert head_bytes(scope) == len(b"GET /a?b=1 HTTP/1.1\r\nh: v\r\n\r\n")
    with TestClient(create_app(Settings(data_dir=tmp_path))) as c:
        for method in ("GET", "HEAD"):
            r = c.request(method, "/healthz", headers={"X-Big": "a" * (MAX_HEAD_BYTES + 1)})
            assert r.status_code == 431, (method, r.status_code)
        assert c.get("/healthz", headers={"X-Big": "a" * 32_000}).status_code == 200
