"""What sends the retention cleanup: ``conformorph worker --beat``, the beat service
of docker-compose.yml (run as written, on Redis) and ``conformorph serve``'s timer."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from conformorph.cli.cmd_serve import CleanupTimer
from conformorph.cli.cmd_worker import add_worker_options, worker_argv
from conformorph.worker.celery_app import celery_config
from conformorph.worker.config import WorkerSettings
from conformorph.worker.job_store import JobStore
from tests.conftest import ROOT


def _args(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    add_worker_options(p)
    return p.parse_args(list(argv))


def test_worker_beat_flag() -> None:
    assert "--beat" in worker_argv(_args("--beat"))
    assert "--beat" not in worker_argv(_args())


def test_beat_schedule_sends_the_cleanup(tmp_path: Path) -> None:
    s = WorkerSettings(data_dir=tmp_path, cleanup_interval_seconds=120)
    entry = celery_config(s)["beat_schedule"]["conformorph-cleanup"]
    assert entry["task"] == "conformorph.cleanup" and entry["schedule"] == 120
    assert entry["options"] == {"queue": "conformorph-interactive"}
    with pytest.raises(ValueError, match="greater than 0"):
        WorkerSettings(data_dir=tmp_path, cleanup_interval_seconds=0)


def test_serve_timer_sends_every_interval_and_survives_failures() -> None:
    calls: list[float] = []
    done = threading.Event()

    def send() -> None:
        calls.append(time.monotonic())
        if len(calls) == 2:
            raise ConnectionError("broker down")  # logged; the timer goes on
        if len(calls) >= 4:
            done.set()

    timer = CleanupTimer(send, interval=0.1, first=0.05)
    timer.start()
    assert done.wait(10)
    timer.stopping.set()
    timer.join(5)
    assert not timer.is_alive()
    assert all(b - a >= 0.09 for a, b in zip(calls, calls[1:], strict=False))


@pytest.mark.redis
@pytest.mark.timeout(120)
def test_compose_beat_runs_the_cleanup(tmp_path: Path, redis_url: str, start_worker: Any) -> None:
    services = yaml.safe_load((ROOT / "docker-compose.yml").read_text())["services"]
    beat_cmd = services["beat"]["command"]
    assert beat_cmd[:4] == ["celery", "-A", "conformorph.worker.celery_app", "beat"]
    assert "artifacts:/data" in services["beat"]["volumes"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
    env.update({k: str(v) for k, v in services["beat"]["environment"].items()})
    env.pop("CONFORMORPH_DATABASE_URL")
    env.update(
        CONFORMORPH_BROKER_URL=redis_url,
        CONFORMORPH_DATA_DIR=str(tmp_path),
        CONFORMORPH_CLEANUP_INTERVAL_SECONDS="1",
        PYTHONPATH=str(ROOT),
    )
    start_worker(env, log=tmp_path / "worker.log")
    exe = Path(sys.executable).parent / "celery"
    beat = subprocess.Popen(
        [str(exe), *beat_cmd[1:]],
        env=env,
        cwd=ROOT,
        stdout=open(tmp_path / "beat.log", "wb"),  # noqa: SIM115
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    try:
        store = JobStore(WorkerSettings(data_dir=tmp_path).resolved_database_url)
        deadline = time.monotonic() + 90
        # each cleanup the worker runs writes its totals (zero here): beat sent it
        while not store.cleanup_totals_recorded():
            assert beat.poll() is None, (tmp_path / "beat.log").read_text()[-3000:]
            assert time.monotonic() < deadline, (tmp_path / "worker.log").read_text()[-3000:]
            time.sleep(0.3)
    finally:
        os.killpg(beat.pid, 9)
        beat.wait()
