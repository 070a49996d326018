"""The paper's QIEM route to the disk conformal map: speed, distortion and flips on the shared faces.

Usage: python benchmarks/bench_qiem.py [--faces DIR] [--repeat 3] [--subdivided] [--all]
       [--schemes lagged,qiem] [--gauss]

Prints, per mesh, the QIEM route (double cover, spherical heat flow,
stereographic projection, boundary normalisation) against the default
``fast`` method: wall time (median of ``--repeat``), heat-flow iterations,
mean/max angle distortion, mean |μ|, flipped triangles and the boundary
circle error. ``--subdivided`` adds choi_human_face subdivided once (midpoint,
68k vertices); ``--all`` every disk face in the folder (ears removed first
where present; the ``_holes`` files are not disks and are skipped);
``--schemes lagged,qiem`` also times the paper's per-step-factorised QIEM;
``--gauss`` also runs the paper's Gauss-map start (slow: 200 steps).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import trimesh

from conformorph import geometry as g
from conformorph.geometry.map_quality import map_quality
from conformorph.geometry.qiem_disk_map import QiemOptions, qiem_disk_conformal_map
from conformorph.pipelines.mesh_io import read_mesh

DEFAULT_FACES = Path(__file__).resolve().parents[2] / "shared" / "data" / "faces"


def timed(fn, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, statistics.median(times)


def row(name, label, V, F, uv, seconds, iterations="", stop=""):
    q = map_quality(V, F, uv, g.boundary_loop(F))
    print(
        f"| {name} | {label} | {seconds:.3f} | {iterations} {stop} | {q.angle_distortion_mean:.3f} | "
        f"{q.angle_distortion_max:.1f} | {q.beltrami_mean:.4f} | {q.flipped} | "
        f"{q.boundary_circle_error:.1e} |"
    )


def bench(name, V, F, args):
    for scheme in args.schemes.split(","):
        opts = QiemOptions(scheme=scheme)
        if scheme == "qiem":
            opts = QiemOptions(scheme=scheme, time_step=0.05, growth=2.0, max_iterations=100)
        (uv, info), t = timed(
            lambda o=opts: qiem_disk_conformal_map(V, F, options=o), args.repeat
        )
        row(name, f"QIEM route ({scheme})", V, F, uv, t, info.iterations, info.stop_reason)
    if args.gauss:
        (uv, info), t = timed(
            lambda: qiem_disk_conformal_map(
                V, F, validate=False, options=QiemOptions(initial_map="gauss")
            ), 1
        )
        row(name, "QIEM route, Gauss-map start", V, F, uv, t, info.iterations, info.stop_reason)
    (uv, info), t = timed(lambda: g.disk_conformal_map(V, F, fold_policy="report"), args.repeat)
    row(name, "fast (default)", V, F, uv, t, info.iterations)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=Path, default=DEFAULT_FACES)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--subdivided", action="store_true")
    ap.add_argument("--all", action="store_true")
    ap.add_argument("--schemes", default="lagged")
    ap.add_argument("--gauss", action="store_true")
    args = ap.parse_args()

    print(
        "| mesh | method | time s | iterations | mean Δ∠ ° | max Δ∠ ° | mean abs mu | flips | bnd err |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    V, F = read_mesh(args.faces / "choi_human_face.obj")
    bench(f"choi_human_face ({len(V)})", V, F, args)
    if args.subdivided:
        Vs, Fs = trimesh.remesh.subdivide(V, F)
        bench(f"choi subdivided ({len(Vs)})", np.asarray(Vs), np.asarray(Fs, dtype=np.int64), args)
    if args.all:
        for path in sorted(args.faces.glob("*.obj")):
            if path.name == "choi_human_face.obj" or "_holes" in path.name:
                continue
            V, F = read_mesh(path)
            note = ""
            if g.boundary_ear_vertices(F).size:
                n0 = len(V)
                V, F, _ = g.remove_boundary_ears(V, F)
                note = f", {n0 - len(V)} ears removed"
            bench(f"{path.stem} ({len(V)}{note})", V, F, args)


if __name__ == "__main__":
    main()
