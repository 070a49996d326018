"""Every command runs one BLAS thread unless told otherwise (set before numpy loads)."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import os, sys
import conformorph.cli.main as m
assert "numpy" not in sys.modules, "conformorph.cli.main must not import numpy before choosing BLAS threads"
try:
    m.main(sys.argv[1:])
except SystemExit:
    pass
print(os.environ.get("OPENBLAS_NUM_THREADS"), "numpy" in sys.modules)
"""


def _probe(*argv: str, **env: str) -> str:
    clean = {
        k: v
        for k, v in os.environ.items()
        if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    }
    out = subprocess.run(
        [sys.executable, "-c", PROBE, *argv],
        cwd=ROOT,
        env={**clean, **env},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    return out.stdout.split("\n")[-2]


def test_commands_limit_blas_threads_before_numpy_loads():
    assert _probe("--help") == "1 True"  # every command registered: numpy is loaded
    assert _probe("map", "--help") == "1 True"
    # only the worker's module is registered for `worker`: numpy is not even loaded
    assert _probe("worker", "--help") == "1 False"


def test_an_explicit_setting_wins():
    assert _probe("--help", OPENBLAS_NUM_THREADS="2") == "2 True"
    assert _probe("map", "--help", OPENBLAS_NUM_THREADS="2") == "2 True"
