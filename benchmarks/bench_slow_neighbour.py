"""Issue 30: while one key sends the worst input of each class, another key's service times.

Starts a real ``conformorph serve`` (embedded broker; its job, validation and
webhook workers) in a temporary data folder with two API keys. For
``--seconds`` the ``hostile`` key sends, each class in its own thread, over and
over: a GLB whose 40,000 nodes form one chain (then a cycle), a shape JSON and a
``.gltf`` of 60,000 escaped quotes, landmark documents of about 3.3 MB (upload,
then ``GET`` of the stored document), jobs whose webhook receiver trickles one
byte every 3 s, malformed callback URLs, and requests with random method
tokens. Meanwhile the ``victim`` key uploads a small mesh (new bytes each time)
and reads its job's status, and ``/healthz`` is probed, each timed in a process of
its own (the hostile threads' JSON work would otherwise hold the timing threads'
GIL: seconds the server never caused).

Prints, per victim request kind, count, failures, p50, p99 and max seconds
(targets: p99 <= 1 s for uploads and status reads, <= 0.1 s for /healthz),
then each hostile class's answers, and ``/metrics``'s size at the end.
Bounded; stops by itself; never part of the tests. Usage::

    .venv/bin/python benchmarks/bench_slow_neighbour.py [--seconds 60]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import random
import string
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter, defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.fixtures.malformed_corpus import _disk, _glb, _glb_parts, valid_disk_files  # noqa: E402
from tests.fixtures.super_linear import chain_nodes, escaped_quotes  # noqa: E402
from tests.live_server import free_port  # noqa: E402
from tests.webhook_receiver import webhook_receiver  # noqa: E402

FACE = ROOT / "tests" / "fixtures" / "service_small_face.obj"


def _quantile(ranked: list[float], q: float) -> float:
    return ranked[min(len(ranked) - 1, int(q * len(ranked)))]


class Timings:
    """Seconds and statuses per request kind (thread-safe)."""

    def __init__(self) -> None:
        self.seconds: dict[str, list[float]] = defaultdict(list)
        self.statuses: dict[str, Counter[str]] = defaultdict(Counter)
        self.lock = threading.Lock()

    def timed(self, kind: str, call: Callable[[], httpx.Response]) -> httpx.Response | None:
        t0 = time.perf_counter()
        try:
            r: httpx.Response | None = call()
            status = str(r.status_code) if r is not None else "none"
        except httpx.HTTPError as exc:
            r, status = None, type(exc).__name__
        with self.lock:
            self.seconds[kind].append(time.perf_counter() - t0)
            self.statuses[kind][status] += 1
        return r

    def report(self, kinds: list[str]) -> None:
        for kind in kinds:
            s = sorted(self.seconds.get(kind, []))
            if not s:
                print(f"{kind:28s} no requests")
                continue
            print(
                f"{kind:28s} n={len(s):5d} p50={_quantile(s, 0.5):7.3f} "
                f"p99={_quantile(s, 0.99):7.3f} "
                f"max={s[-1]:7.3f}  {dict(self.statuses[kind])}"
            )


def _hostile_classes(base: str, auth: dict[str, str], receiver_url: str) -> dict[str, Callable]:
    V, F = _disk()
    doc, binary = _glb_parts(V, F)
    mesh_id: list[str] = []

    def chain(k: int) -> httpx.Response:
        nodes = chain_nodes(40_000 + k % 2, cycle=k % 2 == 1)  # accepted, then refused
        data = _glb(doc | {"nodes": nodes, "extras": {"k": k}}, binary)
        return httpx.post(
            f"{base}/v1/meshes", files={"file": ("chain.glb", data)}, headers=auth, timeout=120
        )

    def quotes_shape(k: int) -> httpx.Response:
        data = escaped_quotes(60_000 + k).encode()
        return httpx.post(
            f"{base}/v1/shapes", files={"file": ("q.json", data)}, headers=auth, timeout=120
        )

    def quotes_gltf(k: int) -> httpx.Response:
        data = escaped_quotes(60_000 + k).encode()
        return httpx.post(
            f"{base}/v1/meshes", files={"file": ("q.gltf", data)}, headers=auth, timeout=120
        )

    def landmarks(k: int) -> httpx.Response:
        pts = [[i * 1e-3 + k, (i % 97) * 1e-2, 0.5] for i in range(70_000)]
        r = httpx.post(
            f"{base}/v1/landmarks", json={"landmarks": [pts, pts]}, headers=auth, timeout=120
        )
        if r.status_code in (200, 201):
            return httpx.get(
                f"{base}/v1/landmarks/{r.json()['id']}/document", headers=auth, timeout=120
            )
        return r

    def mesh() -> str:
        """The hostile key's face mesh, uploaded once (its own request, not counted)."""
        if not mesh_id:
            up = httpx.post(
                f"{base}/v1/meshes",
                files={"file": ("face.obj", FACE.read_bytes())},
                headers=auth,
                timeout=120,
            )
            mesh_id.append(up.json()["id"])
        return mesh_id[0]

    def slow_webhook(k: int) -> httpx.Response:
        r = httpx.post(
            f"{base}/v1/conformal-maps",
            json={"mesh": mesh(), "callback_url": receiver_url},
            headers=auth,
            timeout=60,
        )
        time.sleep(5.0)  # a few jobs, each with a trickling receiver
        return r

    def bad_url(k: int) -> httpx.Response:
        url = ["http://[::1", "http://[", "https://[x]", "http://]", "http://[2002:a00:1::]/"]
        return httpx.post(
            f"{base}/v1/conformal-maps",
            json={"mesh": mesh(), "callback_url": url[k % len(url)]},
            headers=auth,
            timeout=60,
        )

    rng = random.Random(30)

    def methods(k: int) -> httpx.Response:
        token = "".join(rng.choices(string.ascii_uppercase, k=8))
        return httpx.request(token, f"{base}/healthz", timeout=30)

    return {
        "hostile GLB node chain": chain,
        "hostile shape quotes": quotes_shape,
        "hostile glTF quotes": quotes_gltf,
        "hostile landmarks 3 MB": landmarks,
        "hostile slow webhook job": slow_webhook,
        "hostile bad callback_url": bad_url,
        "hostile random methods": methods,
    }


def _loop(stop: threading.Event, pause: float, fn: Callable[[int], object]) -> None:
    k = 0
    while not stop.is_set():
        fn(k)
        k += 1
        stop.wait(pause)


def _victim_requests(base: str, key: str, job: str) -> dict[str, tuple[float, Callable]]:
    """Each victim request kind: (pause between requests, the request).

    Each kind has its own ``httpx.Client`` (one thread each), as a monitoring probe
    or an SDK keeps one: ``httpx.get`` builds a client, and so an SSL context, per
    call (about 60 ms of the prober's own CPU at load 13, measured here), which
    would be counted as the server's latency.
    """
    victim = {"Authorization": f"Bearer {key}"}
    disk = valid_disk_files()["obj"]
    up, status, health = (httpx.Client(timeout=120) for _ in range(3))
    return {
        "victim upload": (
            0.5,
            lambda k: up.post(
                f"{base}/v1/meshes",
                files={"file": (f"v{k}.obj", disk + f"# {k} {time.time()}\n".encode())},
                headers=victim,
            ),
        ),
        "victim status read": (
            0.2,
            lambda k: status.get(f"{base}/v1/jobs/{job}", headers=victim),
        ),
        "/healthz": (0.1, lambda k: health.get(f"{base}/healthz")),
    }


def victim_process(base: str, key: str, job: str, seconds: float, out: Any) -> None:
    """The victim's requests, timed in a process of their own.

    The hostile threads build and parse multi-megabyte bodies in Python; timed in
    the same process, the victim's seconds would include waits for that process's
    GIL, which the server never caused. Results go back through ``out`` (a queue).
    """
    t = Timings()
    stop = threading.Event()
    threads = [
        threading.Thread(target=_loop, args=(stop, p, lambda k, c=c, n=n: t.timed(n, lambda: c(k))))
        for n, (p, c) in _victim_requests(base, key, job).items()
    ]
    for th in threads:
        th.start()
    stop.wait(seconds)
    stop.set()
    for th in threads:
        th.join(180)
    out.put((dict(t.seconds), {k: dict(v) for k, v in t.statuses.items()}))


def run(
    base: str, keys: dict[str, str], seconds: float, receiver_url: str, skip: list[str]
) -> Timings:
    t = Timings()
    hostile = {"Authorization": f"Bearer {keys['hostile']}"}
    victim = {"Authorization": f"Bearer {keys['victim']}"}
    first = httpx.post(
        f"{base}/v1/meshes", files={"file": ("face.obj", FACE.read_bytes())}, headers=victim
    )
    job = httpx.post(
        f"{base}/v1/conformal-maps", json={"mesh": first.json()["id"]}, headers=victim
    ).json()["id"]
    stop = threading.Event()
    threads = [
        threading.Thread(
            target=_loop, args=(stop, 0.05, lambda k, c=c, n=n: t.timed(n, lambda: c(k)))
        )
        for n, c in _hostile_classes(base, hostile, receiver_url).items()
        if not any(s and s in n for s in skip)
    ]
    for th in threads:
        th.start()
    time.sleep(1.0)
    ctx = multiprocessing.get_context("spawn")
    out = ctx.Queue()
    proc = ctx.Process(target=victim_process, args=(base, keys["victim"], job, seconds, out))
    proc.start()
    seconds_by_kind, statuses = out.get(timeout=seconds + 300)
    proc.join(60)
    stop.set()
    for th in threads:
        th.join(180)
    for kind, values in seconds_by_kind.items():
        t.seconds[kind] = values
        t.statuses[kind] = Counter(statuses[kind])
    return t


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument(
        "--skip",
        default="",
        help="comma-separated parts of hostile class names not to send ('hostile': none, "
        "a baseline of the victim alone on this machine)",
    )
    ap.add_argument(
        "--worker-nice",
        type=int,
        help="serve's --worker-nice (default: serve's own); 0 runs the workers at the API's "
        "priority, for a comparison in one run",
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-neighbour-") as tmp:
        env = {
            **os.environ,
            "PYTHONPATH": str(ROOT),
            "CONFORMORPH_DATA_DIR": tmp,
            "CONFORMORPH_CALLBACK_ALLOW": "public,127.0.0.0/8",
            "CONFORMORPH_CALLBACK_TIMEOUT": "5",
            "CONFORMORPH_MAX_ACTIVE_JOBS": "1000",
        }
        env.pop("CONFORMORPH_BROKER_URL", None)
        keys = {}
        for name in ("hostile", "victim"):
            out = subprocess.run(
                [sys.executable, "-m", "conformorph.cli", "keys", "create", name],
                env=env, cwd=ROOT, capture_output=True, text=True, check=True, timeout=120,
            )  # fmt: skip
            keys[name] = out.stdout.split()[-1]
        port = free_port()
        proc = subprocess.Popen(
            [sys.executable, "-m", "conformorph.cli", "serve", "--port", str(port),
             *(["--worker-nice", str(args.worker_nice)] if args.worker_nice is not None else [])],
            env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        base = f"http://127.0.0.1:{port}"
        try:
            deadline = time.monotonic() + 240
            while time.monotonic() < deadline:
                try:
                    if httpx.get(f"{base}/readyz", timeout=3).status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                time.sleep(0.5)
            else:
                print("server did not become ready", file=sys.stderr)
                return 1
            with webhook_receiver(default=200, trickle=3.0) as rx:
                t = run(base, keys, args.seconds, rx.url, args.skip.split(","))
            victims = ["victim upload", "victim status read", "/healthz"]
            print(
                f"{args.seconds:g} s of hostile traffic, loadavg {os.getloadavg()}, "
                f"worker nice {args.worker_nice if args.worker_nice is not None else 'default'}"
            )
            t.report(victims)
            t.report(sorted(k for k in t.seconds if k.startswith("hostile")))
            size = len(httpx.get(f"{base}/metrics", timeout=60).content)
            print(f"/metrics: {size} bytes")
            jobs = httpx.get(
                f"{base}/v1/jobs", headers={"Authorization": f"Bearer {keys['hostile']}"}
            ).json()
            print("hostile jobs:", json.dumps(jobs)[:300])
        finally:
            proc.terminate()
            proc.wait(60)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
