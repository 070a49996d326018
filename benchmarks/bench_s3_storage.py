"""S3 artifact storage: time and peak Python memory of a big file up, down and streamed.

Runs moto's S3 server (``python -m moto.server``, its own process on 127.0.0.1),
so the times are those of a local HTTP endpoint, not of a real object store;
the memory is the client's alone (``tracemalloc`` in this process).

    python benchmarks/bench_s3_storage.py [--mib 96] [--part-mib 8]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from conformorph.worker.s3_storage import S3Options, S3Storage  # noqa: E402
from tests.s3_server import AWS_TEST_ENV, run_moto_server  # noqa: E402

MiB = 1 << 20


def _measured(step: Callable[[], Any]) -> tuple[float, float]:
    """(seconds, peak traced MiB) of one call."""
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        step()
        seconds = time.perf_counter() - t0
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return seconds, peak / MiB


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mib", type=int, default=96, help="file size in MiB")
    ap.add_argument("--part-mib", type=int, default=8, help="multipart part size in MiB")
    args = ap.parse_args()
    os.environ.update(AWS_TEST_ENV)
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "big.bin"
        with open(src, "wb") as f:
            for i in range(args.mib):
                f.write(hashlib.sha256(str(i).encode()).digest() * (MiB // 32))
        server = run_moto_server()
        endpoint = next(server)
        try:
            bucket = endpoint.new_bucket()

            def storage(name: str) -> S3Storage:
                opts = S3Options(
                    bucket=bucket,
                    prefix="bench",
                    cache_dir=Path(tmp) / name,
                    endpoint_url=endpoint.url,
                    addressing_style="path",
                    part_bytes=args.part_mib * MiB,
                )
                return S3Storage(opts)

            up, down = storage("up"), storage("down")
            key = "jobs/bench/big.bin"

            def stream() -> None:
                with down.open(key) as f:
                    while f.read(256 * 1024):
                        pass

            rows = [
                ("put_file (multipart upload)", _measured(lambda: up.put_file(key, src))),
                ("local_path (download to cache)", _measured(lambda: down.local_path(key))),
                ("open + read (ranged GET stream)", _measured(stream)),
            ]
        finally:
            server.close()
    print(f"file {args.mib} MiB, parts {args.part_mib} MiB, moto S3 server on 127.0.0.1")
    print(f"{'step':34s} {'seconds':>8s} {'MiB/s':>7s} {'peak MiB':>9s}")
    for name, (seconds, peak) in rows:
        print(f"{name:34s} {seconds:8.2f} {args.mib / seconds:7.1f} {peak:9.1f}")


if __name__ == "__main__":
    main()
