"""``conformorph serve`` runs its embedded workers at a lower CPU priority than its API.

Issue 30: on the two cores the API shares with its workers, a neighbour's validation
or morph kept ``/healthz`` and status reads waiting for the CPU. The workers (and
every process they start) run with ``serve --worker-nice`` (default 10) added to the
API's niceness, so the scheduler serves the API's requests first.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from conformorph.cli.cmd_serve import WORKER_NICE
from tests.live_server import ROOT, LiveServer, _descendants


def test_every_worker_process_yields_the_cpu_to_the_api(live_server: LiveServer) -> None:
    api = os.getpriority(os.PRIO_PROCESS, live_server.proc.pid)
    # the API's own helpers (its landmark-upload pool) are not workers: only the
    # processes started as ``conformorph.cli worker`` and what they start
    heads = [p for p in _descendants(live_server.proc.pid) if _is_worker_command(p)]
    workers = set(heads).union(*(_descendants(p) for p in heads))
    assert len(heads) >= 3, heads  # jobs, interactive, webhooks (and their pools)
    nices = {pid: os.getpriority(os.PRIO_PROCESS, pid) for pid in workers}
    assert all(n == min(api + WORKER_NICE, 19) for n in nices.values()), (api, nices)


def _is_worker_command(pid: int) -> bool:
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return False
    return b"conformorph.cli" in argv and b"worker" in argv


@pytest.mark.parametrize(("nice", "expect"), [(0, 0), (3, 3)])
def test_worker_nice_option_lowers_priority_by_n(nice: int, expect: int) -> None:
    code = (
        "import os; from conformorph.cli.cmd_worker import lower_priority; "
        f"before = os.getpriority(os.PRIO_PROCESS, 0); lower_priority({nice}); "
        "print(os.getpriority(os.PRIO_PROCESS, 0) - before)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert int(out.stdout) == expect


def test_a_negative_nice_is_refused_with_exit_2() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "conformorph.cli", "serve", "--worker-nice", "-5", "--port", "1"],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert out.returncode == 2
    assert "--worker-nice must be 0 or more" in out.stderr
    assert "Traceback" not in out.stderr
