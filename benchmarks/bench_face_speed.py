"""Speed and peak memory of the face morph, end to end (maps, registration, frames, GLB).

Run:  .venv/bin/python benchmarks/bench_face_speed.py [--case ict|big] [--refine PRESET] [--repeat N]

Two ICT faces (7k vertices, 30 frames) as in the issue's target (≤ 3 s), and
two 68k-vertex faces (``choi_human_face`` subdivided once, the second one
deformed by a smooth displacement; 30 landmarks by farthest-point sampling)
for the ≤ 30 s target. Key metrics off (they are extra work for the
benchmark tables, not the product path). One BLAS thread, as the
``conformorph`` command sets (``conformorph.cli.main.limit_blas_threads``; the
environment's ``OPENBLAS_NUM_THREADS`` wins). Each case runs in its own process
and reports that process's peak resident memory (``ru_maxrss``), which
includes the Python interpreter and the imported libraries (~100 MB).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from conformorph.cli.main import limit_blas_threads  # noqa: E402

limit_blas_threads()  # as the conformorph command runs: before numpy loads

import numpy as np  # noqa: E402

from benchmarks.bench_face_tables import subdivide  # noqa: E402
from conformorph.geometry.static_correspondences import farthest_point_samples  # noqa: E402
from conformorph.pipelines.face_morph import (  # noqa: E402
    FaceMorphOptions,
    FrameOptions,
    RegistrationOptions,
    run_face_morph,
)
from conformorph.pipelines.mesh_io import read_mesh, write_obj  # noqa: E402

FACES = ROOT.parent / "shared" / "data" / "faces"


#: DMT refinement preset of the run (``--refine``; default the pipeline's own)
REFINE: dict[str, str] = {}


def _run(paths: list[Path], L: Path, out: Path) -> dict:
    t = time.perf_counter()
    options = FaceMorphOptions(
        frames=30,
        registration=RegistrationOptions(**REFINE),
        homotopy=FrameOptions(key_metrics=False),
    )
    m = run_face_morph(paths, L, out, options)
    m["wall"] = time.perf_counter() - t
    return m


def _peak_rss_mb() -> float:
    """Peak resident memory of this process so far (Linux reports ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def case_ict(d: Path) -> None:
    lm = json.loads((FACES / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    L = d / "ict.json"
    L.write_text(json.dumps({"landmarks": [lm, lm]}))
    m = _run([FACES / "ict_generic_neutral.obj", FACES / "ict_generic_smile.obj"], L, d / "o1")
    n = m["registration"]["consistent_mesh"]["n_vertices"]
    print(
        f"ICT {n / 1000:.0f}k x2, 30 frames: {m['wall']:.2f} s  stages {_fmt(m['seconds'])}  "
        f"peak RSS {_peak_rss_mb():.0f} MB"
    )


def case_big(d: Path) -> None:
    V, F = read_mesh(FACES / "choi_human_face.obj")
    V, F = subdivide(V, F)
    c = V.mean(axis=0)
    diam = np.linalg.norm(V.max(0) - V.min(0))
    V2 = V + 0.03 * diam * np.sin(3 * (V - c) / diam)[:, [1, 2, 0]]
    write_obj(d / "a.obj", V, F)
    write_obj(d / "b.obj", V2, F)
    inner = np.flatnonzero(np.linalg.norm(V[:, :2] - c[:2], axis=1) < 0.3 * diam)
    ids = farthest_point_samples(V, 30, candidates=inner).tolist()
    L2 = d / "big.json"
    L2.write_text(json.dumps({"landmarks": [ids, ids]}))
    m = _run([d / "a.obj", d / "b.obj"], L2, d / "o2")
    print(
        f"{V.shape[0] // 1000}k x2, 30 frames: {m['wall']:.2f} s  stages {_fmt(m['seconds'])}  "
        f"peak RSS {_peak_rss_mb():.0f} MB"
    )
    its = m["frames"]["reconstruction_iterations"]
    print(f"  CG iterations per frame (1 = factorised afresh): {its}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=("ict", "big"), help="run one case in this process")
    ap.add_argument(
        "--refine",
        choices=("auto", "nicp", "guided", "static", "none"),
        help="DMT refinement preset (default: the pipeline's default)",
    )
    ap.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="run every case this many times, each in a fresh process (timings on a "
        "shared machine vary by ±15%%: report the median)",
    )
    args = ap.parse_args()
    if args.refine:
        REFINE["refine"] = args.refine
    if not FACES.exists():
        sys.exit(f"shared data not found at {FACES}")
    if args.case:
        with tempfile.TemporaryDirectory() as tmp:
            (case_ict if args.case == "ict" else case_big)(Path(tmp))
        return
    # each case in its own process, so that its peak memory is its own
    extra = ["--refine", args.refine] if args.refine else []
    for case in ("ict", "big"):
        for _ in range(max(1, args.repeat)):
            subprocess.run([sys.executable, __file__, "--case", case, *extra], check=True)


def _fmt(s: dict) -> str:
    return ", ".join(f"{k} {v:.2f}" for k, v in s.items() if k != "total")


if __name__ == "__main__":
    main()
