"""Service benchmarks for issue 5's targets; prints tables (never part of the tests).

Starts real processes: the API (``conformorph serve --workers 0``), one
worker for the interactive queue and N job workers, all on the embedded
broker in a temporary data folder (or on Redis with ``--broker``).

1. ``e2e``: upload two ICT faces, submit a 30-frame morph, wait, fetch
   ``animation.glb``; one job worker. Target ≤ 5 s. Needs ../shared/data.
2. ``latency``: ``GET /v1/jobs/{id}`` at a fixed 200 requests/s for a few
   seconds from an asyncio load generator on loopback; p50/p99/max.
   Target p99 ≤ 20 ms.
3. ``throughput``: 20 morph jobs submitted at once with 1 and with 2 job
   workers; all must succeed; target speed-up ≥ 1.7.

Usage::

    .venv/bin/python benchmarks/bench_service.py [--part all|e2e|latency|throughput]
        [--broker redis://127.0.0.1:6379/12] [--jobs 20] [--rate 200] [--seconds 5]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FACES = ROOT.parent / "shared" / "data" / "faces"
sys.path.insert(0, str(ROOT))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Stack:
    """API + interactive worker + N job workers, in their own process groups."""

    def __init__(self, job_workers: int, broker: str | None) -> None:
        self.tmp = tempfile.TemporaryDirectory(prefix="conformorph-bench-")
        self.env = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
        self.env.update(CONFORMORPH_DATA_DIR=self.tmp.name, PYTHONPATH=str(ROOT))
        if broker:
            import redis

            redis.Redis.from_url(broker).flushdb()
            self.env["CONFORMORPH_BROKER_URL"] = broker
        self.port = _free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        py = [sys.executable, "-m", "conformorph.cli"]
        cmds = [[*py, "serve", "--workers", "0", "--port", str(self.port), "--loglevel", "WARNING"]]
        cmds.append(
            [
                *py,
                "worker",
                "--queues",
                "interactive",
                "--loglevel",
                "WARNING",
                "--name",
                "interactive",
            ]
        )
        for i in range(job_workers):
            cmds.append(
                [*py, "worker", "--queues", "jobs", "--loglevel", "WARNING", "--name", f"jobs{i}"]
            )
        self.procs = [
            subprocess.Popen(
                c,
                env=self.env,
                cwd=ROOT,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
            for c in cmds
        ]
        deadline = time.monotonic() + 180
        while True:
            try:
                if httpx.get(f"{self.base}/readyz", timeout=10).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline or self.procs[0].poll() is not None:
                self.close()
                raise RuntimeError("the API did not come up")
            time.sleep(0.2)
        time.sleep(3.0)  # let the workers finish starting

    def close(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in self.procs:
            try:
                p.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        self.tmp.cleanup()


def upload(c: httpx.Client, path: Path) -> str:
    with open(path, "rb") as f:
        r = c.post("/v1/meshes", files={"file": (path.name, f.read())}, timeout=120)
    r.raise_for_status()
    return str(r.json()["id"])


def wait(c: httpx.Client, job_id: str, timeout: float = 600) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        job: dict[str, Any] = c.get(f"/v1/jobs/{job_id}").json()
        if job["state"] not in ("queued", "running"):
            return job
        if time.monotonic() > deadline:
            raise TimeoutError(job_id)
        time.sleep(0.02)


def ict_inputs() -> tuple[list[Path], list[list[int]]]:
    from conformorph.pipelines.landmarks_io import parse_landmark_json

    meshes = [FACES / "ict_generic_neutral.obj", FACES / "ict_generic_smile.obj"]
    lm = parse_landmark_json(json.loads((FACES / "ict_landmarks68.json").read_text()), 2)
    return meshes, lm


def small_inputs(tmp: Path) -> tuple[list[Path], list[list[int]]]:
    from conformorph.pipelines.mesh_io import write_obj
    from tests.fixtures.make_service_small_face import small_face

    V, F = small_face(10)
    W = V.copy()
    W[:, 2] += 3.0 * np.sin(V[:, 0] / 30.0)
    a, b = tmp / "small_a.obj", tmp / "small_b.obj"
    write_obj(a, V, F)
    write_obj(b, W, F)
    r = np.linalg.norm(V[:, :2] / np.array([80.0, 100.0]), axis=1)
    ring = np.flatnonzero(np.abs(r - 0.5) < 0.02)
    lm = [0, *[int(i) for i in ring[:: max(1, ring.size // 8)][:8]]]
    return [a, b], [lm, lm]


def bench_e2e(broker: str | None) -> None:
    if not FACES.is_dir():
        print("e2e: ../shared/data/faces missing; skipped")
        return
    meshes, lm = ict_inputs()
    stack = Stack(1, broker)
    try:
        with httpx.Client(base_url=stack.base) as c:
            rows = []
            for run in range(2):
                t0 = time.perf_counter()
                ids = [upload(c, p) for p in meshes]
                t_up = time.perf_counter()
                r = c.post(
                    "/v1/morphs",
                    json={"meshes": ids, "landmarks": lm, "frames": 30, "method": "dmt"},
                )
                r.raise_for_status()
                jid = r.json()["id"]
                # the animation is published by the export stage, before the metrics stage
                while True:
                    job = c.get(f"/v1/jobs/{jid}").json()
                    if any(a["name"] == "animation.glb" for a in job["artifacts"]) or job[
                        "state"
                    ] not in (
                        "queued",
                        "running",
                    ):
                        break
                    time.sleep(0.02)
                glb = c.get(f"/v1/jobs/{jid}/artifacts/animation.glb")
                t_glb = time.perf_counter()
                job = wait(c, jid)
                t_end = time.perf_counter()
                assert job["state"] == "succeeded" and glb.content[:4] == b"glTF", job
                stages = {s["name"]: s["seconds"] for s in job["stages"]}
                rows.append((run, t_up - t0, t_glb - t0, t_end - t0, len(glb.content), stages))
        print(
            "\n## Upload to fetched animation.glb: ICT neutral -> smile, 30 frames, DMT, 1 worker (target <= 5 s)"
        )
        print(
            "| run | upload s | animation.glb fetched s | job done (with metrics) s | glb bytes | stage seconds |"
        )
        print("|---|---|---|---|---|---|")
        for run, up, tg, tot, size, st in rows:
            note = " (new uploads)" if run == 0 else " (uploads deduplicated)"
            print(f"| {run}{note} | {up:.2f} | {tg:.2f} | {tot:.2f} | {size} | {json.dumps(st)} |")
    finally:
        stack.close()


async def _load(port: int, path: str, rate: float, seconds: float) -> tuple[list[float], int]:
    """Open-loop load: one GET every 1/rate s on keep-alive connections (raw asyncio
    HTTP/1.1, so the generator is not the bottleneck); latency from the scheduled send
    time, so queueing delay counts (no coordinated omission)."""
    idle: asyncio.Queue[tuple[asyncio.StreamReader, asyncio.StreamWriter]] = asyncio.Queue()
    request = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode()
    lat: list[float] = []
    errors = 0

    async def one(t_sched: float) -> None:
        nonlocal errors
        try:
            conn = idle.get_nowait()
        except asyncio.QueueEmpty:
            conn = await asyncio.open_connection("127.0.0.1", port)
        reader, writer = conn
        writer.write(request)
        head = await reader.readuntil(b"\r\n\r\n")
        status = int(head.split(b" ", 2)[1])
        length = 0
        for line in head.split(b"\r\n"):
            if line.lower().startswith(b"content-length:"):
                length = int(line.split(b":")[1])
        await reader.readexactly(length)
        lat.append(time.perf_counter() - t_sched)
        if status != 200:
            errors += 1
        idle.put_nowait(conn)

    tasks = []
    t0 = time.perf_counter()
    for i in range(int(rate * seconds)):
        t_sched = t0 + i / rate
        delay = t_sched - time.perf_counter()
        if delay > 0:
            await asyncio.sleep(delay)
        tasks.append(asyncio.create_task(one(t_sched)))
    await asyncio.gather(*tasks)
    while not idle.empty():
        idle.get_nowait()[1].close()
    return lat, errors


def bench_latency(broker: str | None, rate: float, seconds: float) -> None:
    stack = Stack(1, broker)
    try:
        with httpx.Client(base_url=stack.base) as c:
            meshes, lm = small_inputs(Path(stack.tmp.name))
            ids = [upload(c, p) for p in meshes]
            r = c.post("/v1/morphs", json={"meshes": ids, "landmarks": lm, "frames": 5})
            job_id = r.json()["id"]
            wait(c, job_id)
        path = f"/v1/jobs/{job_id}"
        asyncio.run(_load(stack.port, path, rate, 1.0))  # warm-up
        lat, errors = asyncio.run(_load(stack.port, path, rate, seconds))
        ms = np.array(lat) * 1000
        print(f"\n## GET /v1/jobs/{{id}} at {rate:g} req/s for {seconds:g} s (target p99 <= 20 ms)")
        print("| requests | errors | p50 ms | p90 ms | p99 ms | max ms | mean ms |")
        print("|---|---|---|---|---|---|---|")
        print(
            f"| {ms.size} | {errors} | {np.percentile(ms, 50):.2f} | {np.percentile(ms, 90):.2f} | "
            f"{np.percentile(ms, 99):.2f} | {ms.max():.2f} | {statistics.fmean(ms):.2f} |"
        )
    finally:
        stack.close()


def _batch(broker: str | None, workers: int, n_jobs: int, use_ict: bool) -> tuple[float, int, int]:
    stack = Stack(workers, broker)
    try:
        with httpx.Client(base_url=stack.base, timeout=60) as c:
            meshes, lm = ict_inputs() if use_ict else small_inputs(Path(stack.tmp.name))
            ids = [upload(c, p) for p in meshes]
            t0 = time.perf_counter()
            jobs = []
            for k in range(n_jobs):
                r = c.post("/v1/morphs", json={"meshes": ids, "landmarks": lm, "frames": 10 + k})
                r.raise_for_status()
                jobs.append(r.json()["id"])
            states = [wait(c, j)["state"] for j in jobs]
            dt = time.perf_counter() - t0
            listed = c.get("/v1/jobs", params={"limit": 200}).json()["total"]
        return dt, states.count("succeeded"), listed
    finally:
        stack.close()


def bench_throughput(broker: str | None, n_jobs: int, use_ict: bool) -> None:
    rows = []
    for workers in (1, 2):
        dt, ok, listed = _batch(broker, workers, n_jobs, use_ict)
        rows.append((workers, dt, ok, listed))
    what = "ICT neutral->smile" if use_ict else "small faces (331 vertices)"
    print(
        f"\n## {n_jobs} morph jobs submitted at once ({what}), embedded={broker is None} (target speed-up >= 1.7)"
    )
    print("| job workers | seconds | succeeded | jobs listed | jobs/s | speed-up |")
    print("|---|---|---|---|---|---|")
    for w, dt, ok, listed in rows:
        print(
            f"| {w} | {dt:.2f} | {ok}/{n_jobs} | {listed} | {n_jobs / dt:.2f} | {rows[0][1] / dt:.2f} |"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default="all", choices=["all", "e2e", "latency", "throughput"])
    ap.add_argument("--broker", default=None, help="Redis URL (default: the embedded broker)")
    ap.add_argument("--jobs", type=int, default=20)
    ap.add_argument("--rate", type=float, default=200.0)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument(
        "--ict", action="store_true", help="throughput with ICT faces instead of small ones"
    )
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} CPUs; python {sys.version.split()[0]}")
    if args.part in ("all", "e2e"):
        bench_e2e(args.broker)
    if args.part in ("all", "latency"):
        bench_latency(args.broker, args.rate, args.seconds)
    if args.part in ("all", "throughput"):
        bench_throughput(args.broker, args.jobs, args.ict)


if __name__ == "__main__":
    main()
