"""Issue 15's hostile-input figures against a real ``conformorph serve`` on loopback.

Starts ``conformorph serve --workers 0`` in a temporary data folder (embedded
broker, no worker: every upload's validation waits its whole timeout, a
validation backlog), creates one API key, then measures:

1. ``status``: ``GET /v1/jobs/{id}`` while ``--uploads`` uploads wait for
   validation (p50, max; before issue 15 up to 235 s), and how long those
   uploads took to get their 503 (the wait is ``--validate-timeout``, wall clock).
2. ``unauthenticated``: a 60 MB multipart upload without a key: the answer,
   its time, how many bytes the server took before answering, the server's
   RSS growth and the files left in the staging folder.
3. ``header``: a request with a 64 MB header on ``/healthz``: the answer, its
   time and the server's RSS growth.

Bounded loops; stops by itself. Never part of the tests. Usage::

    .venv/bin/python benchmarks/bench_hostile_service.py [--uploads 40] [--validate-timeout 10]
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import psutil

ROOT = Path(__file__).resolve().parents[1]
FACE = ROOT / "tests" / "fixtures" / "service_small_face.obj"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _rss_mb(pid: int) -> float:
    return psutil.Process(pid).memory_info().rss / 2**20


def _send_raw(port: int, head: bytes, body_chunks: int = 0, chunk: bytes = b"") -> tuple[str, int]:
    """Send ``head`` then up to ``body_chunks`` chunks; (status line, bytes sent)."""
    sent = 0
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        try:
            s.sendall(head)
            sent += len(head)
            s.settimeout(0.0)
            for _ in range(body_chunks):
                try:
                    s.sendall(chunk)
                    sent += len(chunk)
                except BlockingIOError:
                    break  # the server does not read: its buffers are full
                except (BrokenPipeError, ConnectionResetError):
                    break
        except (BrokenPipeError, ConnectionResetError):
            pass
        s.settimeout(30)
        try:
            answer = s.recv(65536)
        except (ConnectionResetError, TimeoutError):
            answer = b""
    return answer.split(b"\r\n", 1)[0].decode(errors="replace") or "(closed)", sent


def _status_during_backlog(base: str, key: str, uploads: int, timeout: float) -> None:
    data = FACE.read_bytes()
    auth = {"Authorization": f"Bearer {key}"}

    def upload(i: int) -> tuple[int, float]:
        t0 = time.monotonic()
        files = {"file": (f"f{i}.obj", data + f"\n# {i}\n".encode())}
        r = httpx.post(f"{base}/v1/meshes", files=files, headers=auth, timeout=timeout * 5)
        return r.status_code, time.monotonic() - t0

    with ThreadPoolExecutor(uploads) as pool:
        futures = [pool.submit(upload, i) for i in range(uploads)]
        time.sleep(2.0)
        took = []
        for _ in range(20):
            t0 = time.monotonic()
            httpx.get(f"{base}/v1/jobs/{'b' * 32}", headers=auth, timeout=300)
            took.append(time.monotonic() - t0)
            time.sleep(0.2)
        results = [f.result() for f in futures]
    waits = [t for _, t in results]
    print(
        f"status read during a backlog of {uploads} uploads: p50 {statistics.median(took) * 1e3:.0f} ms,"
        f" max {max(took) * 1e3:.0f} ms (20 reads)"
    )
    print(
        f"  the uploads' answers: {sorted({c for c, _ in results})}, after "
        f"{min(waits):.1f}-{max(waits):.1f} s (validate timeout {timeout:g} s)"
    )


def _unauthenticated_upload(port: int, pid: int, staging: Path) -> None:
    total = 60 * 2**20
    boundary = "benchbound"
    pre = (
        f'--{boundary}\r\nContent-Disposition: form-data; name="file"; filename="big.obj"\r\n'
        "Content-Type: application/octet-stream\r\n\r\n"
    ).encode()
    head = (
        f"POST /v1/meshes HTTP/1.1\r\nHost: 127.0.0.1\r\n"
        f"Content-Type: multipart/form-data; boundary={boundary}\r\n"
        f"Content-Length: {total + len(pre)}\r\n\r\n"
    ).encode() + pre
    rss0 = _rss_mb(pid)
    t0 = time.monotonic()
    status, sent = _send_raw(port, head, body_chunks=60, chunk=b"v 0 0 0\n" * (2**17))
    took = time.monotonic() - t0
    left = len(list(staging.iterdir())) if staging.is_dir() else 0
    print(
        f"unauthenticated 60 MB upload: {status} in {took * 1e3:.0f} ms; the client got "
        f"{sent / 2**20:.1f} MB into the socket; server RSS {rss0:.0f} -> {_rss_mb(pid):.0f} MB; "
        f"{left} staging files"
    )


def _long_header(port: int, pid: int) -> None:
    rss0 = _rss_mb(pid)
    t0 = time.monotonic()
    # the header sent 1 MB at a time, as long as the server takes it
    head = b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: "
    status, sent = _send_raw(port, head, body_chunks=64, chunk=b"a" * 2**20)
    took = time.monotonic() - t0
    print(
        f"64 MB header on /healthz: {status} in {took * 1e3:.0f} ms ({sent / 2**20:.1f} MB sent "
        f"before the answer); server RSS {rss0:.0f} -> {_rss_mb(pid):.0f} MB"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--uploads", type=int, default=40)
    ap.add_argument("--validate-timeout", type=float, default=10.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-hostile-") as tmp:
        env = {
            **os.environ,
            "PYTHONPATH": str(ROOT),
            "CONFORMORPH_DATA_DIR": tmp,
            "CONFORMORPH_VALIDATE_TIMEOUT": str(args.validate_timeout),
        }
        env.pop("CONFORMORPH_BROKER_URL", None)
        out = subprocess.run(
            [sys.executable, "-m", "conformorph.cli", "keys", "create", "bench"],
            env=env,
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
            timeout=120,
        )
        key = out.stdout.split()[-1]
        port = _free_port()
        proc = subprocess.Popen(
            [sys.executable, "-m", "conformorph.cli", "serve", "--port", str(port), "--workers", "0"],
            env=env,
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        base = f"http://127.0.0.1:{port}"
        try:
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:
                try:
                    if httpx.get(f"{base}/healthz", timeout=2).status_code == 200:
                        break
                except httpx.HTTPError:
                    time.sleep(0.2)
            else:
                print("server did not start", file=sys.stderr)
                return 1
            staging = next(Path(tmp).rglob("staging"), Path(tmp) / "staging")
            _long_header(port, proc.pid)
            _unauthenticated_upload(port, proc.pid, staging)
            _status_during_backlog(base, key, args.uploads, args.validate_timeout)
            r = httpx.get(f"{base}/readyz", timeout=10).json()
            print(f"/readyz during/after the backlog: {r['status']} {r['checks']}")
        finally:
            proc.terminate()
            proc.wait(30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
