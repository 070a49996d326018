"""Batch target of issue 6: 20 ICT morphs through ``conformorph batch`` on a local server.

Starts ``conformorph serve --workers 2`` (embedded broker, temporary data
folder), writes a manifest of 20 distinct ICT face morphs (pairs of the
shared ICT expressions and identities), runs ``conformorph batch`` as a
subprocess, interrupts it with SIGINT once half the jobs are finished, runs
it again to completion, and checks that the second run redid no finished job
(same job ids, nothing uploaded again, 20 jobs in all on the server).

    .venv/bin/python benchmarks/bench_batch.py [--jobs 20] [--frames 10] [--parallel 4]

Needs ../shared/data/faces (exits with a message otherwise).
"""

from __future__ import annotations

import argparse
import itertools
import json
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.live_server import LiveServer  # noqa: E402

FACES = ROOT.parent / "shared" / "data" / "faces"
STATE = ".conformorph-batch.json"


def manifest(folder: Path, n: int, frames: int) -> Path:
    names = sorted(p.name for p in FACES.glob("ict_*.obj"))
    pairs = list(itertools.permutations(names, 2))[:n]
    if len(pairs) < n:
        raise SystemExit(f"only {len(pairs)} ICT pairs available")
    jobs = []
    for i, (a, b) in enumerate(pairs):
        jobs.append(
            {
                "name": f"{i:02d}-{a[4:-4]}-to-{b[4:-4]}",
                "meshes": [str(FACES / a), str(FACES / b)],
                "landmarks": str(FACES / "ict_landmarks68.json"),
                "frames": frames,
            }
        )
    path = folder / "manifest.json"
    path.write_text(json.dumps({"jobs": jobs}, indent=1))
    return path


def done_jobs(out: Path) -> dict[str, str]:
    try:
        st = json.loads((out / STATE).read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return {}
    return {k: v["job_id"] for k, v in st["jobs"].items() if v.get("status") == "done"}


def summary_numbers(text: str) -> dict[str, int]:
    m = re.search(r"done (\d+), skipped (\d+), failed (\d+); uploads (\d+)", text)
    if m is None:
        return {}
    return dict(zip(("done", "skipped", "failed", "uploads"), map(int, m.groups()), strict=True))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=20)
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--parallel", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    if not (FACES / "ict_landmarks68.json").exists():
        raise SystemExit(f"ICT faces not found in {FACES}")
    with tempfile.TemporaryDirectory(prefix="bench-batch-") as tmp:
        tmpd = Path(tmp)
        srv = LiveServer(tmpd / "server", workers=args.workers)
        try:
            srv.wait_ready()
            m = manifest(tmpd, args.jobs, args.frames)
            out = tmpd / "out"
            cmd = [sys.executable, "-m", "conformorph.cli", "batch", str(m), "--server", srv.url]
            cmd += ["-o", str(out), "--parallel", str(args.parallel), "-q"]

            t0 = time.monotonic()
            first = subprocess.Popen(
                cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
            while first.poll() is None and len(done_jobs(out)) < args.jobs // 2:
                time.sleep(0.2)
            first.send_signal(signal.SIGINT)
            _, err1 = first.communicate(timeout=60)
            t1 = time.monotonic()
            before = done_jobs(out)

            second = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
            t2 = time.monotonic()
            after = done_jobs(out)
            nums = summary_numbers(second.stdout)
            total = httpx.get(f"{srv.url}/v1/jobs", params={"limit": 1}).json()["total"]
            redone = [k for k, v in before.items() if after.get(k) != v]
            jobs_state = httpx.get(f"{srv.url}/v1/jobs", params={"limit": 200}).json()["items"]
            runs = [j["finished_at"] - j["started_at"] for j in jobs_state if j["finished_at"]]
        finally:
            srv.stop()
    rows = [
        ("jobs in the manifest", args.jobs),
        ("server job workers (concurrency)", args.workers),
        ("batch --parallel", args.parallel),
        ("frames per morph", args.frames),
        ("first run: exit code (SIGINT)", first.returncode),
        ("first run: jobs finished before the interrupt", len(before)),
        ("first run: seconds", f"{t1 - t0:.1f}"),
        ("second run: exit code", second.returncode),
        ("second run: jobs skipped (finished before)", nums.get("skipped")),
        ("second run: jobs finished", nums.get("done")),
        ("second run: failed", nums.get("failed")),
        ("second run: uploads", nums.get("uploads")),
        ("second run: seconds", f"{t2 - t1:.1f}"),
        ("finished jobs redone", len(redone)),
        ("jobs on the server (no duplicates when = manifest)", total),
        ("all jobs finished", len(after) == args.jobs),
        ("median job run time on the server, s", f"{sorted(runs)[len(runs) // 2]:.1f}"),
        ("wall time for the whole batch, s", f"{t2 - t0:.1f}"),
        ("throughput, morphs per minute", f"{60 * len(after) / (t2 - t0):.1f}"),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"{'quantity':<{width}}  value")
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    if second.returncode != 0:
        print(second.stdout[-2000:], second.stderr[-2000:], err1[-1000:], sep="\n")


if __name__ == "__main__":
    main()
