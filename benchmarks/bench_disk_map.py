"""Disk conformal map: speed and distortion against libigl, on the shared faces.

Usage: python benchmarks/bench_disk_map.py [--faces DIR] [--repeat 3] [--methods fast,qiem]

Needs the ``bench`` extra (``pip install -e '.[bench]'``) for libigl. Prints:
1. choi_human_face and its once-subdivided version: our default method versus
   ``igl.lscm`` (free boundary, two pinned vertices) and ``igl.harmonic``
   (arc-length boundary on the circle), timed in the same run (median of
   ``--repeat``), with the ratio ours / lscm;
2. every face in the folder with each method: distortion, flips before and
   after the fold repair, boundary circularity.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import trimesh

from conformorph import geometry as g
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


def igl_maps(V, F, repeat):
    import igl

    b = g.boundary_loop(F)
    pins = np.array([b[0], b[len(b) // 2]])
    (uv_l, _), t_l = timed(lambda: igl.lscm(V, F, pins, np.array([[0.0, 0], [1, 0]])), repeat)
    bnd = igl.boundary_loop(F)
    circ = igl.map_vertices_to_circle(V, bnd)
    uv_h, t_h = timed(lambda: igl.harmonic(V, F, bnd, circ, 1), repeat)
    return (uv_l, t_l), (uv_h, t_h)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=Path, default=DEFAULT_FACES)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--methods", default="fast")
    args = ap.parse_args()
    methods = args.methods.split(",")

    V, F = read_mesh(args.faces / "choi_human_face.obj")
    V2, F2 = trimesh.remesh.subdivide(V, F)
    print("## Speed and distortion against libigl (median of", args.repeat, "runs)")
    print("| mesh | V | method | seconds | mean Δ∠ ° | max Δ∠ ° | flips | ratio to lscm |")
    print("|---|---|---|---|---|---|---|---|")
    for name, (VV, FF) in (("choi_human_face", (V, F)), ("choi subdivided once", (V2, F2))):
        (uv_l, t_l), (uv_h, t_h) = igl_maps(VV, FF, args.repeat)
        rows = [("igl.lscm", uv_l, t_l), ("igl.harmonic", uv_h, t_h)]
        for m in methods:
            (uv, info), t = timed(
                lambda m=m, VV=VV, FF=FF: g.disk_conformal_map(VV, FF, method=m), args.repeat
            )
            rows.append((f"conformorph {m}", uv, t))
        for label, uv, t in rows:
            d = g.angle_distortion(VV, FF, uv)
            flips = int(g.flipped_triangles(uv, FF).sum())
            flips = min(flips, len(FF) - flips)  # lscm may come out mirrored
            print(
                f"| {name} | {len(VV)} | {label} | {t:.3f} | {d.mean():.4f} | {d.max():.1f} | {flips} | {t / t_l:.2f} |"
            )

    print("\n## Every shared face")
    print(
        "| face | V | method | seconds | mean Δ∠ ° | flips before repair | flips | repaired vertices | max ||uv_b|-1| | input repair |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for path in sorted(args.faces.glob("*.obj")):
        VV, FF = read_mesh(path)
        fix = "none"
        try:
            g.validate_mesh(VV, FF)
        except g.BoundaryEarError:
            n0 = len(VV)
            VV, FF, _ = g.remove_boundary_ears(VV, FF)
            fix = f"{n0 - len(VV)} ears removed"
        except g.NotDiskError:
            # what the CLI's --fill-holes does: a fan to the centroid of each inner loop
            n0 = len(VV)
            VV, FF = g.fill_holes(VV, FF)
            fix = f"{len(VV) - n0} holes filled"
        for m in methods:
            t = time.perf_counter()
            uv, info = g.disk_conformal_map(VV, FF, method=m)
            t = time.perf_counter() - t
            d = g.angle_distortion(VV, FF, uv)
            print(
                f"| {path.stem} | {len(VV)} | {m} | {t:.3f} | {d.mean():.3f} | {info.flipped_before_repair} | "
                f"{info.flipped} | {info.repaired_vertices} | {info.boundary_circle_error:.1e} | {fix} |"
            )


if __name__ == "__main__":
    main()
