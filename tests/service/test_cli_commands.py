"""``conformorph keys``, ``serve`` (a real server with its worker processes), ``worker`` options."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import psutil  # a declared test dependency (pyproject's "test" extra): no skip without it
import pytest

from conformorph.cli.main import main
from conformorph.worker.job_store import JobStore
from tests.conftest import ROOT


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _env(data_dir: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
    env.update(PYTHONPATH=str(ROOT), CONFORMORPH_DATA_DIR=str(data_dir))
    return env


def test_keys_create_prints_the_key_last(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CONFORMORPH_DATA_DIR", str(tmp_path / "elsewhere"))
    assert main(["keys", "create", "alice", "--data-dir", str(tmp_path)]) == 0
    key = capsys.readouterr().out.split()[-1]
    store = JobStore(f"sqlite:///{tmp_path / 'jobs.sqlite'}")
    assert store.key_id_for(key) is not None and store.count_keys() == 1
    assert main(["keys", "list", "--data-dir", str(tmp_path)]) == 0
    assert "alice" in capsys.readouterr().out
    store.dispose()


def test_serve_refuses_open_mode_off_loopback(tmp_path: Path) -> None:
    out = subprocess.run(
        [sys.executable, "-m", "conformorph.cli", "serve", "--host", "0.0.0.0", "--data-dir", str(tmp_path)],
        capture_output=True,
        text=True,
        env=_env(tmp_path),
        cwd=ROOT,
        timeout=60,
    )
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "no API keys" in lines[0] and "Traceback" not in out.stderr


@pytest.mark.timeout(120)
def test_serve_runs_api_and_workers(tmp_path: Path, small_face_path: Path) -> None:
    port = _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "conformorph.cli", "serve", "--port", str(port), "--data-dir", str(tmp_path)],
        env=_env(tmp_path / "ignored-env-dir"),
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{base}/readyz", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert proc.poll() is None and time.monotonic() < deadline, "serve did not come up"
            time.sleep(0.2)
        workers = psutil.Process(proc.pid).children()
        assert len(workers) == 3  # jobs, validation (interactive) and webhook deliveries
        with open(small_face_path, "rb") as f:
            r = httpx.post(f"{base}/v1/meshes", files={"file": ("face.obj", f.read())}, timeout=60)
        assert r.status_code == 201, r.text
        r = httpx.post(f"{base}/v1/reconstructions", json={"mesh": r.json()["id"]}, timeout=10)
        assert r.status_code == 202
        url = base + r.headers["location"]
        while (job := httpx.get(url, timeout=5).json())["state"] in ("queued", "running"):
            assert time.monotonic() < deadline + 30
            time.sleep(0.1)
        assert job["state"] == "succeeded", job
        assert (tmp_path / "jobs.sqlite").exists() and (tmp_path / "broker" / "queue").is_dir()
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            _, err = proc.communicate()
    assert "running OPEN" in err.decode()
    for w in workers:
        assert not w.is_running() or w.status() == psutil.STATUS_ZOMBIE


@pytest.mark.timeout(120)
def test_workers_exit_when_serve_is_killed(tmp_path: Path) -> None:
    port = _free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "conformorph.cli", "serve", "--port", str(port), "--data-dir", str(tmp_path)],
        env=_env(tmp_path),
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    workers: list[object] = []
    try:
        deadline = time.monotonic() + 60
        while len(workers) < 3:
            assert proc.poll() is None and time.monotonic() < deadline, (
                "serve did not start its workers"
            )
            workers = psutil.Process(proc.pid).children()
            time.sleep(0.2)
        time.sleep(3.0)  # let the workers finish starting
    finally:
        proc.kill()  # SIGKILL: serve cannot clean up
        proc.wait()
    gone, alive = psutil.wait_procs(workers, timeout=45)  # type: ignore[arg-type]
    for w in alive:  # pragma: no cover - only on failure
        os.killpg(w.pid, signal.SIGKILL)
    assert not alive, f"orphaned workers: {[w.pid for w in alive]}"
