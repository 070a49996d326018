"""Issue 30, items 9 and 10, against a real ``conformorph serve`` on loopback.

1. ``broker``: a private ``redis-server`` (append-only file on) as the broker; ``--jobs``
   face morphs submitted at once (one worker process, so they queue); Redis SIGKILLed
   while the first runs and restarted ``--outage`` seconds later. Reports when each
   job ended after the broker's return, and from the job store how many times each
   stage was claimed (once each = no stage ran twice) and how often a job was sent again.
2. ``s3``: moto's S3 server behind a TCP proxy that this script cuts and restores (the
   store's host gone: connections refused). With a finished job A and a morph B
   running when the store goes, for ``--outage`` seconds: artifact GET/HEAD of A, an
   upload, DELETE of A and a new morph C are tried every few seconds (statuses and
   Retry-After counted; any 500 is a failure); after the store returns: when B and C
   ended, and DELETE of A then leaves no object under its prefix.

Faces: two ICT faces from ``--faces`` (default ``../shared/data/faces`` beside the
repository) with their 68 landmarks, else the committed small test face and a
stretched copy. Bounded waits; stops by itself; never part of the tests. Usage::

    .venv/bin/python benchmarks/bench_faults.py [--scenario both] [--jobs 6] [--outage 16]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path
from typing import Any

import httpx

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "tests" / "fixtures" / "service_small_face.obj"
AWS = {
    "AWS_ACCESS_KEY_ID": "bench",
    "AWS_SECRET_ACCESS_KEY": "bench-secret",
    "AWS_DEFAULT_REGION": "us-east-1",
    "AWS_CONFIG_FILE": "/nonexistent",
    "AWS_SHARED_CREDENTIALS_FILE": "/nonexistent",
}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_port(port: int, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.05)
    raise RuntimeError(f"nothing listens on port {port}")


class Proxy:
    """A TCP forwarder to ``target`` that can be cut (listener and connections closed:
    connections refused) and restored on the same port."""

    def __init__(self, target: int) -> None:
        self.target, self.port = target, free_port()
        self.conns: list[socket.socket] = []
        self.listener: socket.socket | None = None
        self.restore()

    def restore(self) -> None:
        lst = socket.socket()
        lst.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        lst.bind(("127.0.0.1", self.port))
        lst.listen(64)
        self.listener = lst
        threading.Thread(target=self._accept, args=(lst,), daemon=True).start()

    def cut(self) -> None:
        if self.listener is not None:
            self.listener.close()
            self.listener = None
        for c in self.conns:
            try:
                c.close()
            except OSError:
                pass
        self.conns.clear()

    def _accept(self, lst: socket.socket) -> None:
        while True:
            try:
                client, _ = lst.accept()
            except OSError:
                return
            try:
                upstream = socket.create_connection(("127.0.0.1", self.target))
            except OSError:
                client.close()
                continue
            self.conns += [client, upstream]
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    @staticmethod
    def _pump(a: socket.socket, b: socket.socket) -> None:
        try:
            while data := a.recv(65536):
                b.sendall(data)
        except OSError:
            pass
        for s in (a, b):
            try:
                s.close()
            except OSError:
                pass


def faces(folder: Path, tmp: Path) -> tuple[Path, Path, dict[str, Any]]:
    """Two key meshes and a landmark document (ICT if ``folder`` has them)."""
    a, b, lm = (
        folder / "ict_generic_neutral.obj",
        folder / "ict_generic_smile.obj",
        folder / "ict_landmarks68.json",
    )
    if a.is_file() and b.is_file() and lm.is_file():
        return a, b, json.loads(lm.read_text())
    out = []
    for line in SMALL.read_text().splitlines():
        if line.startswith("v "):
            x, y, z = (float(t) for t in line.split()[1:4])
            line = f"v {x * 1.05:.6f} {y:.6f} {z * 1.2 + 0.02 * x:.6f}"
        out.append(line)
    b = tmp / "small_b.obj"
    b.write_text("\n".join(out) + "\n")
    return SMALL, b, {"nearest_vertex_0based": [0, 40, 80, 120, 160, 200, 240, 280, 320]}


class Served:
    """``conformorph serve`` with one worker process in ``data``, with ``env`` added."""

    def __init__(self, data: Path, env: dict[str, str]) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        full = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
        full.update(env, PYTHONPATH=str(ROOT), CONFORMORPH_DATA_DIR=str(data))
        self.log = open(data.parent / f"{data.name}.log", "ab")  # noqa: SIM115
        cmd = [sys.executable, "-m", "conformorph.cli", "serve", "--port", str(self.port)]
        self.proc = subprocess.Popen(
            [*cmd, "--data-dir", str(data), "--workers", "1"],
            env=full,
            cwd=ROOT,
            stdout=self.log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self.http = httpx.Client(base_url=self.url, timeout=60)
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline:
            try:
                if self.http.get("/readyz").json().get("status") == "ready":
                    return
            except (httpx.HTTPError, ValueError):
                pass
            time.sleep(0.5)
        raise RuntimeError("conformorph serve did not get ready")

    def upload(self, path: Path) -> str:
        r = self.http.post("/v1/meshes", files={"file": (path.name, path.read_bytes())})
        r.raise_for_status()
        return str(r.json()["id"])

    def morph(self, ids: list[str], landmarks_id: str) -> str:
        body = {"meshes": ids, "landmarks_id": landmarks_id, "frames": 5}
        r = self.http.post("/v1/morphs", json=body)
        if r.status_code != 202:
            raise RuntimeError(f"morph refused: {r.status_code} {r.text}")
        return str(r.json()["id"])

    def state(self, job_id: str) -> str:
        return str(self.http.get(f"/v1/jobs/{job_id}").json()["state"])

    def stop(self) -> None:
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait()
        self.http.close()
        self.log.close()


def wait_all(srv: Served, jobs: list[str], since: float, limit: float) -> dict[str, Any]:
    """Each job's end state and its seconds after ``since`` (None: not within ``limit``)."""
    out: dict[str, Any] = {j: None for j in jobs}
    while time.monotonic() - since < limit and any(v is None for v in out.values()):
        for j in jobs:
            if out[j] is None:
                st = srv.state(j)
                if st in ("succeeded", "failed", "cancelled"):
                    out[j] = (st, round(time.monotonic() - since, 1))
        time.sleep(0.25)
    return out


def claims(data: Path, jobs: list[str]) -> dict[str, tuple[int, int, int]]:
    """(claims, stages, requeues) of each job, from the job store."""
    sys.path.insert(0, str(ROOT))
    from conformorph.worker.job_store import JobStore

    store = JobStore(f"sqlite:///{data / 'jobs.sqlite'}", create=False)
    out = {}
    for j in jobs:
        row = store.get_job(j)
        out[j] = (-1, -1, -1) if row is None else (row.attempts, len(row.stages), row.requeues)
    store.dispose()
    return out


def run_broker(tmp: Path, a: Path, b: Path, lm: dict[str, Any], n_jobs: int, outage: float) -> bool:
    binary = shutil.which("redis-server")
    if binary is None:
        print("broker: no redis-server binary; skipped")
        return True
    port, rdir = free_port(), tmp / "redis"
    rdir.mkdir()
    rcmd = [binary, "--port", str(port), "--bind", "127.0.0.1", "--save", ""]
    rcmd += ["--appendonly", "yes", "--dir", str(rdir)]
    redis = subprocess.Popen(rcmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wait_port(port)
    data = tmp / "broker-data"
    srv = Served(data, {"CONFORMORPH_BROKER_URL": f"redis://127.0.0.1:{port}/0"})
    try:
        ids = [srv.upload(a), srv.upload(b)]
        lid = srv.http.post("/v1/landmarks", json=lm).json()["id"]
        jobs = [srv.morph(ids, lid) for _ in range(n_jobs)]
        while srv.state(jobs[0]) != "running":
            time.sleep(0.1)
        redis.send_signal(signal.SIGKILL)
        redis.wait()
        t_kill = time.monotonic()
        time.sleep(outage)
        redis = subprocess.Popen(rcmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_port(port)
        back = time.monotonic()
        print(f"broker: Redis SIGKILLed, back {back - t_kill:.1f} s later; {n_jobs} morphs queued")
        ends = wait_all(srv, jobs, back, 300.0)
        counts = claims(data, jobs)
        ok = True
        for k, j in enumerate(jobs):
            c, stages, requeues = counts[j]
            print(
                f"  job {k + 1}: {ends[j]} s after the return; {c} claims for {stages} stages, sent again {requeues}x"
            )
            ok &= (
                ends[j] is not None
                and ends[j][0] == "succeeded"
                and ends[j][1] <= 60
                and c == stages
            )
        print(
            f"broker: {'met' if ok else 'MISSED'} (every job succeeded within 60 s, each stage once)"
        )
        return ok
    finally:
        srv.stop()
        if redis.poll() is None:
            redis.kill()
            redis.wait()


def run_s3(tmp: Path, a: Path, b: Path, lm: dict[str, Any], outage: float) -> bool:
    import boto3

    mport = free_port()
    moto = subprocess.Popen(
        [sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p", str(mport)],
        env={**os.environ, **AWS},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    wait_port(mport)
    s3 = boto3.client(
        "s3",
        endpoint_url=f"http://127.0.0.1:{mport}",
        **{
            "region_name": AWS["AWS_DEFAULT_REGION"],
            "aws_access_key_id": AWS["AWS_ACCESS_KEY_ID"],
            "aws_secret_access_key": AWS["AWS_SECRET_ACCESS_KEY"],
        },
    )
    s3.create_bucket(Bucket="bench")
    proxy = Proxy(mport)
    env = {
        **AWS,
        "CONFORMORPH_STORAGE_URL": "s3://bench/artifacts",
        "CONFORMORPH_S3_ENDPOINT_URL": f"http://127.0.0.1:{proxy.port}",
        "CONFORMORPH_S3_ADDRESSING_STYLE": "path",
    }
    srv = Served(tmp / "s3-data", env)
    try:
        ids = [srv.upload(a), srv.upload(b)]
        lid = srv.http.post("/v1/landmarks", json=lm).json()["id"]
        job_a = srv.morph(ids, lid)
        wait_all(srv, [job_a], time.monotonic(), 300.0)
        art = f"/v1/jobs/{job_a}/artifacts/metrics.json"
        job_b = srv.morph(ids, lid)
        while srv.state(job_b) not in ("running", "succeeded", "failed"):
            time.sleep(0.05)
        proxy.cut()
        t0 = time.monotonic()
        seen: Counter[str] = Counter()
        job_c = None
        while time.monotonic() - t0 < outage:
            for name, call in (
                ("GET artifact", lambda: srv.http.get(art)),
                ("HEAD artifact", lambda: srv.http.head(art)),
                (
                    "upload",
                    lambda: srv.http.post(
                        "/v1/meshes", files={"file": ("x.obj", SMALL.read_bytes())}
                    ),
                ),
                ("DELETE job", lambda: srv.http.delete(f"/v1/jobs/{job_a}")),
            ):
                r = call()
                retry = "Retry-After" in r.headers
                seen[f"{name} {r.status_code}{' +Retry-After' if retry else ''}"] += 1
            if job_c is None:
                job_c = srv.morph(ids, lid)  # needs no storage to be accepted
            time.sleep(2.0)
        proxy.restore()
        back = time.monotonic()
        print(f"s3: store cut for {back - t0:.1f} s while morph B ran; answers during the outage:")
        for k, v in sorted(seen.items()):
            print(f"  {k}: {v}")
        ends = wait_all(srv, [job_b, job_c], back, 600.0)
        print(
            f"  morph B: {ends[job_b]} s after the return; morph C (submitted during it): {ends[job_c]}"
        )
        deleted = srv.http.delete(f"/v1/jobs/{job_a}").status_code
        left = s3.list_objects_v2(Bucket="bench", Prefix=f"artifacts/jobs/{job_a}/").get(
            "KeyCount", 0
        )
        print(f"  DELETE A after the return: {deleted}; objects left under its prefix: {left}")
        counts = claims(tmp / "s3-data", [job_b, job_c])
        print(f"  claims/stages/requeues: B {counts[job_b]}, C {counts[job_c]}")
        no500 = not any(" 500" in k for k in seen) and all(" 503 +Retry-After" in k for k in seen)
        ok = no500 and deleted == 204 and left == 0
        ok &= all(v is not None and v[0] == "succeeded" for v in ends.values())
        print(
            f"s3: {'met' if ok else 'MISSED'} (only 503 + Retry-After, jobs finished, nothing orphaned)"
        )
        return ok
    finally:
        srv.stop()
        proxy.cut()
        moto.kill()
        moto.wait()


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", choices=["broker", "s3", "both"], default="both")
    p.add_argument("--jobs", type=int, default=6, help="morphs queued at the broker restart")
    p.add_argument("--outage", type=float, default=16.0, help="seconds each outage lasts")
    p.add_argument("--faces", type=Path, default=ROOT.parent / "shared" / "data" / "faces")
    p.add_argument("--keep", type=Path, help="work in this (new) folder and keep the logs")
    args = p.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory(prefix="bench-faults-") as d:
        tmp = Path(d) if args.keep is None else args.keep
        tmp.mkdir(parents=True, exist_ok=True)
        a, b, lm = faces(args.faces, tmp)
        print(f"faces: {a.name}, {b.name}")
        ok = True
        if args.scenario in ("broker", "both"):
            ok &= run_broker(tmp, a, b, lm, args.jobs, args.outage)
        if args.scenario in ("s3", "both"):
            ok &= run_s3(tmp, a, b, lm, args.outage)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
