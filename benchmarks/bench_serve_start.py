"""Issue 31's start-up target: ``bash scripts/serve.sh`` a second time, nothing changed,
is ready (``GET /readyz`` 200) in at most 5 s.

Runs the script ``--runs`` times in a row against a temporary data folder and prints,
per start, the seconds until ``/readyz`` answered 200, with the machine's load average;
then, for comparison, ``conformorph serve`` started directly (what serve.sh execs once
its stamps match), so the part serve.sh itself adds is the difference. The first start
installs whatever the stamps in ``.venv`` say changed (minutes on a fresh clone).

    python3 benchmarks/bench_serve_start.py [--runs 3] [--port 8941]

Each server is stopped (SIGTERM to the process it started) before the next starts.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]


def seconds_to_ready(cmd: list[str], port: int, log: Path, timeout: float = 600.0) -> float:
    """Start ``cmd``, poll ``/readyz`` every 50 ms, stop it; seconds to the first 200."""
    t0 = time.perf_counter()
    with log.open("wb") as fh:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT)
    try:
        while time.perf_counter() - t0 < timeout:
            if proc.poll() is not None:
                raise SystemExit(f"{cmd[0]} exited with {proc.returncode}: see {log}")
            try:
                if httpx.get(f"http://127.0.0.1:{port}/readyz", timeout=1).status_code == 200:
                    return time.perf_counter() - t0
            except httpx.TransportError:
                pass
            time.sleep(0.05)
        raise SystemExit(f"not ready after {timeout:.0f} s: see {log}")
    finally:
        proc.terminate()
        proc.wait(timeout=60)
        time.sleep(2)  # its workers follow it down (they watch its pid)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--port", type=int, default=8941)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "data"
        flags = ["--port", str(args.port), "--data-dir", str(data)]
        rows = []
        for k in range(args.runs):
            s = seconds_to_ready(["bash", "scripts/serve.sh", *flags], args.port, Path(tmp) / "s.log")
            rows.append(("serve.sh", k + 1, s, os.getloadavg()[0]))
        serve = [str(ROOT / ".venv" / "bin" / "conformorph"), "serve", *flags]
        for k in range(args.runs):
            s = seconds_to_ready(serve, args.port, Path(tmp) / "d.log")
            rows.append(("conformorph serve", k + 1, s, os.getloadavg()[0]))
    print(f"{'command':<18} {'start':>5} {'ready s':>8} {'load 1m':>8}")
    for name, k, s, load in rows:
        print(f"{name:<18} {k:>5} {s:>8.2f} {load:>8.2f}")
    later = [s for name, k, s, _ in rows if name == "serve.sh" and k > 1]
    if later:
        verdict = "met" if max(later) <= 5.0 else "missed"
        print(f"second and later serve.sh starts: max {max(later):.2f} s (target 5 s: {verdict})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
