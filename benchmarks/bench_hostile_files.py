"""Cost of refusing a hostile file: read + validate time per class of the malformed corpus.

Usage: python benchmarks/bench_hostile_files.py [--repeat 3]

Generates ``tests/fixtures/malformed_corpus.py``'s files in memory and runs
each through the upload validation (``conformorph.pipelines.upload_validation``, the code a
worker runs for ``POST /v1/meshes`` and ``/v1/shapes``, with the API's default
limits), taking the fastest of ``--repeat`` runs per file. Prints, per corpus
class and per format, the number of files, the median and the maximum in
milliseconds, and any file that was not refused (there should be none). A
timing assertion in the test suite would be flaky on a shared machine; these
figures are the record.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from conformorph.pipelines.mesh_io import MeshLimits  # noqa: E402
from conformorph.pipelines.upload_validation import validate_mesh_upload, validate_shape_upload  # noqa: E402
from tests.fixtures.malformed_corpus import CorpusFile, corpus, valid_disk_files  # noqa: E402

#: the API's defaults (conformorph.service.core.config.Settings)
LIMITS = MeshLimits(max_vertices=300_000, max_faces=600_000)
MAX_SHAPE_POINTS = 2_000


def refuse(f: CorpusFile) -> dict:
    """The upload validation's answer for one file."""
    if f.kind == "mesh":
        return validate_mesh_upload(f.data, f.ext, LIMITS)
    return validate_shape_upload(f.data, "." + f.ext, max_points=MAX_SHAPE_POINTS)


def fastest_ms(f: CorpusFile, repeat: int) -> tuple[float, dict]:
    best, answer = float("inf"), {}
    for _ in range(repeat):
        t0 = time.perf_counter()
        answer = refuse(f)
        best = min(best, (time.perf_counter() - t0) * 1e3)
    return best, answer


def table(title: str, groups: dict[str, list[float]]) -> None:
    sys.stdout.write(f"\n{title:14s} {'files':>6s} {'median ms':>10s} {'max ms':>9s}\n")
    for name in sorted(groups):
        ms = groups[name]
        sys.stdout.write(f"{name:14s} {len(ms):6d} {statistics.median(ms):10.2f} {max(ms):9.2f}\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per file (fastest kept)")
    args = parser.parse_args()
    for ext, data in valid_disk_files().items():  # warm-up: imports and first parses
        validate_mesh_upload(data, ext, LIMITS)
    by_class: dict[str, list[float]] = defaultdict(list)
    by_format: dict[str, list[float]] = defaultdict(list)
    accepted, slowest = [], []
    for f in corpus():
        ms, answer = fastest_ms(f, args.repeat)
        by_class[f.klass].append(ms)
        by_format[f.ext].append(ms)
        slowest.append((ms, f.name, str(answer.get("error", {}).get("type"))))
        if answer.get("ok"):
            accepted.append(f.name)
    n = sum(len(v) for v in by_class.values())
    sys.stdout.write(f"{n} malformed files, fastest of {args.repeat} runs each\n")
    table("class", by_class)
    table("format", by_format)
    sys.stdout.write("\nslowest five:\n")
    for ms, name, etype in sorted(slowest, reverse=True)[:5]:
        sys.stdout.write(f"  {ms:8.2f} ms  {name}  ({etype})\n")
    sys.stdout.write(f"\naccepted (should be none): {accepted or 'none'}\n")
    return 1 if accepted else 0


if __name__ == "__main__":
    sys.exit(main())
