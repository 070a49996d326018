"""``conformorph map`` and ``conformorph reconstruct``: the conformal core on one mesh."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

import geometry
from worker.mesh_io import read_mesh, write_obj


def _add_mesh_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help="input mesh (OBJ, PLY, OFF, STL, GLB)")
    p.add_argument("--method", choices=["fast", "qiem"], default="fast", help="disk map method")
    p.add_argument("--remove-ears", action="store_true", help="remove boundary ear vertices first")
    p.add_argument("--fill-holes", action="store_true", help="fill inner boundary loops first")
    p.add_argument("--json", action="store_true", help="print one JSON object with the results")


def load_disk_mesh(args: argparse.Namespace) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Read the mesh and apply the requested repairs; returns V, F and what was done."""
    V, F = read_mesh(args.mesh)
    done: dict[str, Any] = {}
    if args.fill_holes:
        n0 = V.shape[0]
        V, F = geometry.fill_holes(V, F)
        done["filled_holes"] = int(V.shape[0] - n0)
    if args.remove_ears:
        n0 = V.shape[0]
        V, F, _ = geometry.remove_boundary_ears(V, F)
        done["removed_ear_vertices"] = int(n0 - V.shape[0])
    return V, F, done


def _quality(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> dict[str, Any]:
    q = geometry.map_quality(V, F, uv)
    d = q.to_dict()
    # the headline figures under stable names, the full report beside them
    return {
        "mean_angle_distortion_deg": float(geometry.angle_distortion(V, F, uv).mean()),
        "flipped_triangles": int(geometry.flipped_triangles(uv, F).sum()),
        "quality": d,
    }


def run_map(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    V, F, done = load_disk_mesh(args)
    uv, info = geometry.disk_conformal_map(V, F, method=args.method)
    out = Path(args.output)
    tmp = out.with_name(out.name + ".tmp.npz")
    np.savez(tmp, uv=uv, faces=F)
    tmp.replace(out)
    result = {
        "mesh": str(args.mesh),
        "output": str(out),
        "vertices": int(V.shape[0]),
        "faces": int(F.shape[0]),
        **done,
        **_quality(V, F, uv),
        "info": info.to_dict(),
        "seconds": time.perf_counter() - t0,
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"{out}: {V.shape[0]} vertices, mean angle distortion "
            f"{result['mean_angle_distortion_deg']:.3f}°, {info.flipped} flipped triangles, "
            f"{info.seconds['total']:.3f} s"
        )
    return 0


def run_reconstruct(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    V, F, done = load_disk_mesh(args)
    # reconstruction needs no bijective map, and the fold repair's mean-value
    # rows would move its Laplacian away from the surface's: report folds only
    uv, info = geometry.disk_conformal_map(V, F, method=args.method, fold_policy="report")
    lam = geometry.conformal_factor(V, F, uv)
    H = geometry.mean_curvature_vector(V, F) if args.curvature == "vector" else geometry.mean_curvature(V, F)
    b = geometry.boundary_loop(F)
    X, rinfo = geometry.reconstruct_surface(uv, F, H, lam, V[b])
    write_obj(args.output, X, F)
    errors = geometry.reconstruction_error(V, X, F)
    result = {
        "mesh": str(args.mesh),
        "output": str(args.output),
        "curvature": args.curvature,
        **done,
        "relative_error": errors,
        "map_flipped_triangles": info.flipped,
        "reconstruction": rinfo.to_dict(),
        "seconds": time.perf_counter() - t0,
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"{args.output}: relative error L1 {errors['L1']:.2e}, L2 {errors['L2']:.2e}, "
            f"L∞ {errors['Linf']:.2e}"
        )
    return 0


def register(sub: Any) -> None:
    """Add the ``map`` and ``reconstruct`` commands."""
    p = sub.add_parser("map", help="disk conformal map of a disk-topology mesh")
    _add_mesh_options(p)
    p.add_argument("-o", "--output", required=True, help="output .npz with uv (n,2) and faces (m,3)")
    p.set_defaults(handler=run_map)
    p = sub.add_parser("reconstruct", help="map, compute (H, λ), reconstruct by Algorithm 1")
    _add_mesh_options(p)
    p.add_argument("-o", "--output", required=True, help="output OBJ, input vertex order")
    p.add_argument(
        "--curvature",
        choices=["vector", "scalar"],
        default="vector",
        help="represent H as the mean-curvature vector (default, one solve) or the paper's scalar",
    )
    p.set_defaults(handler=run_reconstruct)
