"""Reconstruction from (H, λ) and the boundary (Algorithm 1) on the shared faces.

Usage: python benchmarks/bench_reconstruct.py [--faces DIR] [--scalar]

For each ICT face and choi_human_face: relative L1, L2, L∞ errors (section 2.3)
of the reconstruction from the mean-curvature vector: "vector" is what
``conformorph reconstruct`` does (one solve, then the fold correction where the
disk map folds), "vector-linear" the one solve alone (``--no-fold-correction``);
with ``--scalar``, also the paper's scalar H with normal updates; then a
refinement study on choi_human_face (0 and 1 subdivisions).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import trimesh

from conformorph import geometry as g
from conformorph.pipelines.mesh_io import read_mesh

DEFAULT_FACES = Path(__file__).resolve().parents[2] / "shared" / "data" / "faces"


def run(V, F, scalar):
    t = time.perf_counter()
    uv, info = g.disk_conformal_map(V, F, fold_policy="report", refine_angles=False)
    lam = g.conformal_factor(V, F, uv)
    b = g.boundary_loop(F)
    out = {}
    Hv = g.mean_curvature_vector(V, F)
    t_map = time.perf_counter() - t
    for mode, correct in (("vector", True), ("vector-linear", False)):
        t = time.perf_counter()
        X, _ = g.reconstruct_surface(uv, F, Hv, lam, V[b], options=g.ReconstructionOptions(correct_folds=correct))
        out[mode] = (g.reconstruction_error(V, X, F), t_map + time.perf_counter() - t)
    if scalar:
        t = time.perf_counter()
        X, ri = g.reconstruct_surface(uv, F, g.mean_curvature(V, F), lam, V[b])
        out["scalar"] = (g.reconstruction_error(V, X, F), time.perf_counter() - t)
    return out, info.flipped


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=Path, default=DEFAULT_FACES)
    ap.add_argument("--scalar", action="store_true")
    args = ap.parse_args()
    print("| face | V | H representation | L1 | L2 | L∞ | seconds | map folds |")
    print("|---|---|---|---|---|---|---|---|")
    paths = sorted(args.faces.glob("ict_*.obj")) + [args.faces / "choi_human_face.obj"]
    for path in paths:
        V, F = read_mesh(path)
        res, flips = run(V, F, args.scalar)
        for mode, (e, t) in res.items():
            print(
                f"| {path.stem} | {len(V)} | {mode} | {e['L1']:.2e} | {e['L2']:.2e} | {e['Linf']:.2e} | {t:.2f} | {flips} |"
            )
    print("\nRefinement (choi_human_face, loop-free midpoint subdivision):")
    V, F = read_mesh(args.faces / "choi_human_face.obj")
    for level in range(2):
        res, _ = run(V, F, False)
        e, t = res["vector"]
        print(f"  level {level}: V = {len(V)}, L2 = {e['L2']:.2e}, L∞ = {e['Linf']:.2e}, {t:.2f} s")
        V, F = trimesh.remesh.subdivide(V, F)


if __name__ == "__main__":
    main()
