"""Issue 30, item 10: after a Redis broker restart, queued jobs run within about a
minute of the broker's return (not at the 15-minute queued lease), each stage once.

A private ``redis-server`` (append-only file on, as the report's) on a free port is
SIGKILLed while one job runs and others wait, and restarted a few seconds later; a
real ``conformorph worker`` process runs the jobs.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from conformorph.pipelines.mesh_io import write_obj
from tests.conftest import _free_port, _redis_binary, _redis_ping
from tests.fixtures.make_service_small_face import small_face
from tests.worker.test_integration import Service, _env

pytestmark = [pytest.mark.timeout(400), pytest.mark.redis]


class PrivateRedis:
    """A redis-server of this test alone (AOF on), killed and restarted by PID."""

    def __init__(self, folder: Path) -> None:
        binary = _redis_binary()
        if binary is None:
            pytest.skip("no redis-server binary")
        self.binary, self.folder, self.port = binary, folder, _free_port()
        folder.mkdir(parents=True, exist_ok=True)
        self.proc: subprocess.Popen[bytes] | None = None
        self.start()

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def start(self) -> None:
        self.proc = subprocess.Popen(
            [self.binary, "--port", str(self.port), "--bind", "127.0.0.1", "--save", ""]
            + ["--appendonly", "yes", "--dir", str(self.folder)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        deadline = time.monotonic() + 10
        while not _redis_ping("127.0.0.1", self.port):
            assert time.monotonic() < deadline and self.proc.poll() is None, "redis did not start"
            time.sleep(0.05)

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
            self.proc.wait()


@pytest.fixture
def private_redis(tmp_path: Path) -> Iterator[PrivateRedis]:
    r = PrivateRedis(tmp_path / "redis")
    yield r
    r.kill()
    shutil.rmtree(r.folder, ignore_errors=True)


def test_queued_jobs_run_soon_after_a_broker_restart(
    tmp_path: Path, start_worker: object, private_redis: PrivateRedis
) -> None:
    V, F = small_face(rings=60)  # a scalar-H reconstruction of a few seconds
    face = tmp_path / "face.obj"
    write_obj(face, V, F)
    env = _env(tmp_path, CONFORMORPH_BROKER_URL=private_redis.url)
    start_worker(env, queues="jobs,interactive", log=tmp_path / "worker.log")  # type: ignore[operator]
    svc = Service(tmp_path, env)
    svc.ready()
    mid = svc.upload(face)
    jobs = [
        svc.submit("/v1/reconstructions", {"mesh": mid, "curvature": "scalar", "method": m})
        for m in ("fast", "qiem", "fast", "qiem")
    ]
    svc.wait(jobs[0], lambda j: j.state == "running", timeout=120)
    private_redis.kill()
    time.sleep(5.0)
    private_redis.start()
    back = time.monotonic()
    for jid in jobs:
        left = 60.0 - (time.monotonic() - back)
        job = svc.finished(jid, timeout=max(left, 1.0))
        assert job["state"] == "succeeded", job
    took = time.monotonic() - back
    for jid in jobs:
        row = svc.store.get_job(jid)
        assert row is not None
        # each stage claimed once (a stage run twice would claim twice), none failed
        assert row.attempts == len(row.stages), (jid, row.attempts, row.stages)
    assert took < 60.0, f"all {len(jobs)} jobs done {took:.1f} s after the broker's return"
