"""A pooled keep-alive connection the server closed while it sat idle.

A client that reuses connections can send a request onto a socket the server is
closing; the answer is "Server disconnected without sending a response". The
client sends a repeatable call (a read, a delete, a content-addressed upload, a
submission with an ``Idempotency-Key``) once more on a new connection, and never
resends a submission that could create a second job.
"""

from __future__ import annotations

import asyncio
import json
import socket
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from pytest_httpx import HTTPXMock

from conformorph_client import AsyncClient, Client, TransportError
from conformorph_client._calls import create_morph, get_job, upload_mesh

BASE = "http://conformorph.test"
RECORDED = Path(__file__).resolve().parents[1] / "fixtures" / "client_recorded" / "exchanges.json"
EX: dict[str, Any] = json.loads(RECORDED.read_text())["exchanges"]
JOB = json.loads(EX["create_morph"]["text"])
MESH = json.loads(EX["upload_mesh_created"]["text"])
STALE = httpx.RemoteProtocolError("Server disconnected without sending a response.")


def test_which_calls_are_repeatable() -> None:
    assert get_job("j").repeatable
    assert upload_mesh(("f.obj", b"")).repeatable
    assert create_morph(["a", "b"], idempotency_key="k").repeatable
    assert not create_morph(["a", "b"]).repeatable


def test_a_read_is_sent_again_after_a_stale_connection(httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_exception(STALE)
    httpx_mock.add_response(url=f"{BASE}/healthz", json={"status": "ok"})
    with Client(BASE) as c:
        assert c.healthz().status == "ok"
    assert len(httpx_mock.get_requests()) == 2


def test_a_keyed_submission_is_sent_again_with_the_same_key(httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_exception(STALE)
    httpx_mock.add_response(url=f"{BASE}/v1/morphs", status_code=202, json=JOB)
    with Client(BASE) as c:
        job = c.create_morph(["a", "b"], landmarks=[[0, 1, 2], [0, 1, 2]], idempotency_key="k1")
    assert job.id == JOB["id"]
    sent = httpx_mock.get_requests()
    assert [r.headers["Idempotency-Key"] for r in sent] == ["k1", "k1"]
    assert json.loads(sent[0].read()) == json.loads(sent[1].read())


def test_an_unkeyed_submission_is_not_sent_twice(httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_exception(STALE)
    with Client(BASE) as c, pytest.raises(TransportError, match="without sending a response"):
        c.create_morph(["a", "b"], landmarks=[[0, 1, 2], [0, 1, 2]])
    assert len(httpx_mock.get_requests()) == 1


def test_a_second_failure_is_raised(httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_exception(STALE)
    httpx_mock.add_exception(STALE)
    with Client(BASE) as c, pytest.raises(TransportError, match="GET .*/healthz"):
        c.healthz()
    assert len(httpx_mock.get_requests()) == 2


def test_a_refused_connection_is_not_retried(httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_exception(httpx.ConnectError("connection refused"))
    with Client(BASE) as c, pytest.raises(TransportError, match="connection refused"):
        c.healthz()
    assert len(httpx_mock.get_requests()) == 1


def test_an_upload_is_sent_again_from_the_start_of_its_file(
    httpx_mock: HTTPXMock, tmp_path: Path
) -> None:
    path = tmp_path / "face.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    httpx_mock.add_exception(STALE)
    httpx_mock.add_response(url=f"{BASE}/v1/meshes", status_code=201, json=MESH)
    with Client(BASE) as c:
        assert c.upload_mesh(path).id == MESH["id"]
    bodies = [r.read() for r in httpx_mock.get_requests()]
    assert len(bodies) == 2 and path.read_bytes() in bodies[1]


def test_async_client_sends_a_read_again(httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_exception(STALE)
    httpx_mock.add_response(url=f"{BASE}/healthz", json={"status": "ok"})

    async def run() -> str:
        async with AsyncClient(BASE) as c:
            return (await c.healthz()).status

    assert asyncio.run(run()) == "ok"
    assert len(httpx_mock.get_requests()) == 2


# ---------------------------------------------------------------- over a real socket


def _read_request(conn: socket.socket) -> bytes:
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = conn.recv(65536)
        if not chunk:
            return b""
        data += chunk
    return data


@pytest.fixture
def closing_server() -> Iterator[tuple[str, list[int]]]:
    """A server that answers the first request on a connection with keep-alive and
    closes the connection, unanswered, when a second request arrives on it."""
    srv = socket.create_server(("127.0.0.1", 0))
    answered: list[int] = []  # requests answered, per connection in order
    body = b'{"status":"ok"}'
    reply = b"HTTP/1.1 200 OK\r\ncontent-type: application/json\r\ncontent-length: %d\r\n\r\n%s" % (
        len(body),
        body,
    )

    stop = threading.Event()
    srv.settimeout(0.1)  # accept() wakes up to see the stop flag

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = srv.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            conn.settimeout(5.0)
            with conn:
                if not _read_request(conn):
                    continue
                conn.sendall(reply)
                answered.append(1)
                _read_request(conn)  # the next request on this connection: no answer

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{srv.getsockname()[1]}", answered
    finally:
        stop.set()
        thread.join(timeout=5)
        srv.close()


def test_real_connection_closed_by_the_server(closing_server: tuple[str, list[int]]) -> None:
    url, answered = closing_server
    with Client(url) as c:
        assert c.healthz().status == "ok"
        # the pooled connection is reused; the server closes it unanswered
        assert c.healthz().status == "ok"
    assert len(answered) == 2  # the second answer came on a new connection


def test_a_download_is_fetched_again_whole(httpx_mock: HTTPXMock, tmp_path: Path) -> None:
    url = f"{BASE}/v1/jobs/j1/artifacts/metrics.json"
    httpx_mock.add_exception(STALE, url=url)
    httpx_mock.add_response(url=url, content=b'{"ok": true}')
    with Client(BASE) as c:
        dest = c.download("j1", "metrics.json", tmp_path / "m.json")
    assert dest.read_bytes() == b'{"ok": true}'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json"]
