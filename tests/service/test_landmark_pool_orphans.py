"""The API's landmark pool processes end when the API is killed outright."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

SCRIPT = """
import os, sys
from conformorph.service.landmark_process import landmark_pool
pool = landmark_pool()
pool.submit(os.getpid).result()  # the pool starts its processes with the first task
print(" ".join(str(p.pid) for p in pool._processes.values()), flush=True)
sys.stdin.read()  # until killed
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie is gone for our purpose (its parent, now init, reaps it)
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_pool_processes_exit_when_the_api_is_sigkilled() -> None:
    api = subprocess.Popen(
        [sys.executable, "-c", SCRIPT],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert api.stdout is not None
        pids = [int(x) for x in api.stdout.readline().split()]
        assert pids and all(_alive(p) for p in pids)
        api.send_signal(signal.SIGKILL)
        api.wait(timeout=10)
        deadline = time.monotonic() + 10
        while any(_alive(p) for p in pids) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(_alive(p) for p in pids), "pool processes outlived the killed API"
    finally:
        if api.poll() is None:
            api.kill()
