"""``conformorph map`` and ``conformorph reconstruct``: the conformal core on one mesh.

Every output keeps the input file's vertices, in its order, and its faces,
whatever the repairs: ``--fill-holes`` adds hole centres that the numerics
use and the outputs leave out; ``--remove-ears`` removes boundary ears from
the numerics, after which the map's ``uv`` puts them back on the unit circle
(:func:`geometry.extend_uv_to_ears`, ``kept`` False for them) and the
reconstruction gives them their input positions (they are boundary
vertices, whose positions are given). The JSON report lists them.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from conformorph import geometry
from conformorph.cli._output import (
    add_quiet_option,
    add_vertex_budget_option,
    stage_progress,
    use_bars,
)
from conformorph.pipelines import job_fields
from conformorph.pipelines.conformal import (
    CurvatureOptions,
    DiskMapOptions,
    ReconstructionStepOptions,
    RepairOptions,
    curvature_step,
    disk_map_step,
    load_disk_mesh,
    reconstruction_step,
    require_interior_vertex,
)
from conformorph.pipelines.mesh_io import write_obj


def _add_mesh_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("mesh", help="input mesh (OBJ, PLY, OFF, STL, GLB)")
    p.add_argument("--method", choices=["fast", "qiem"], default="fast", help="disk map method")
    p.add_argument("--remove-ears", action="store_true", help="remove boundary ear vertices first")
    p.add_argument("--fill-holes", action="store_true", help="fill inner boundary loops first")
    p.add_argument(
        "--prepare",
        choices=job_fields.PREPARE_CHOICES,
        default=job_fields.MAP_PREPARE_DEFAULT,
        help="'auto': prepare the mesh first (as 'conformorph prepare'); the output is then on "
        "the prepared mesh and OUT.prepare.json maps its vertices to the file's "
        "(default 'none')",
    )
    add_vertex_budget_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object with the results")
    add_quiet_option(p)


@dataclass(frozen=True)
class MapCommandOptions:
    """``conformorph map``/``reconstruct`` flags as the steps' options."""

    repairs: RepairOptions
    disk_map: DiskMapOptions
    curvature: CurvatureOptions
    reconstruction: ReconstructionStepOptions


def map_options_from_args(args: argparse.Namespace) -> MapCommandOptions:
    """The one place the commands' flags become options.

    ``map``: the map as asked (``--no-angle-refinement``), folds repaired.
    ``reconstruct``: reconstruction needs no bijective map, and the fold
    repair's mean-value rows would move its Laplacian away from the
    surface's: folds are reported only; and it runs on the harmonic map
    itself, which the disk Laplacian reproduces the surface from (the angle
    refinement would not: ``refine_angles`` in
    :func:`conformorph.geometry.disk_conformal_map`).
    """
    reconstruct = bool(args.reconstruct)
    curvature: Literal["vector", "scalar"] = (
        "scalar" if getattr(args, "curvature", "vector") == "scalar" else "vector"
    )
    return MapCommandOptions(
        repairs=RepairOptions(
            fill_holes=args.fill_holes,
            remove_ears=args.remove_ears,
            prepare=args.prepare,
            vertex_budget=args.vertex_budget,
        ),
        disk_map=DiskMapOptions(
            method=args.method,
            fold_policy="report" if reconstruct else "repair",
            refine_angles=not reconstruct and not getattr(args, "no_angle_refinement", False),
        ),
        curvature=CurvatureOptions(curvature=curvature),
        reconstruction=ReconstructionStepOptions(
            fold_correction=curvature == "vector" and not getattr(args, "no_fold_correction", False)
        ),
    )


def _write_preparation(mesh: Any, output: str | Path) -> dict[str, Any]:
    """``OUT.prepare.json`` (the report and the vertex map) when ``--prepare auto`` changed the
    mesh; returns the JSON report's additions."""
    if "preparation" not in mesh.done:
        return {}
    if mesh.vertex_map is None:
        return {"vertex_map_file": None}
    out = Path(output)
    sidecar = out.with_name(out.name + ".prepare.json")
    tmp = sidecar.with_name(sidecar.name + ".tmp")
    doc = {**mesh.done["preparation"], "vertex_map": mesh.vertex_map.tolist()}
    tmp.write_text(json.dumps(doc))
    tmp.replace(sidecar)
    return {"vertex_map_file": str(sidecar)}


def run_map(args: argparse.Namespace) -> int:
    with stage_progress(use_bars(args.quiet), "map") as progress:
        return _run_map(args, progress)


def _run_map(args: argparse.Namespace, progress: Callable[[float, str], None]) -> int:
    t0 = time.perf_counter()
    opts = map_options_from_args(args)
    progress(0.0, "reading")
    mesh = load_disk_mesh(args.mesh, opts.repairs)
    V, F = mesh.V, mesh.F
    progress(0.2, f"disk map ({args.method})")
    result = disk_map_step(mesh, opts.disk_map)
    info = result.info
    progress(0.8, "quality and output")
    # every output keeps the input's vertices and faces: removed ears are put
    # back on the unit circle (an unfolded disk map of the whole input)
    out = Path(args.output)
    tmp = out.with_name(out.name + ".tmp.npz")
    extra = {} if mesh.vertex_map is None else {"vertex_map": mesh.vertex_map}
    np.savez(tmp, uv=result.uv_input, faces=mesh.F_in, kept=result.kept, **extra)  # type: ignore[arg-type]
    tmp.replace(out)
    q = geometry.map_quality(V, F, result.uv, geometry.boundary_loop(F))
    result_json = {
        "mesh": str(args.mesh),
        "output": str(out),
        "vertices": int(mesh.V_in.shape[0]),
        "faces": int(mesh.F_in.shape[0]),
        "mapped_vertices": int(V.shape[0]),
        "mapped_faces": int(F.shape[0]),
        **mesh.done,
        **_write_preparation(mesh, out),
        # the headline figures under stable names, the full report beside them
        "mean_angle_distortion_deg": float(q.angle_distortion_mean),
        "flipped_triangles": int(q.flipped),
        "quality": q.to_dict(),
        "info": info.to_dict(),
        "seconds": time.perf_counter() - t0,
    }
    if args.json:
        print(json.dumps(result_json))
    else:
        print(
            f"{out}: {V.shape[0]} vertices, mean angle distortion "
            f"{result_json['mean_angle_distortion_deg']:.3f}°, {info.flipped} flipped triangles, "
            f"{info.seconds['total']:.3f} s"
        )
    return 0


def run_reconstruct(args: argparse.Namespace) -> int:
    with stage_progress(use_bars(args.quiet), "reconstruct") as progress:
        return _run_reconstruct(args, progress)


def _run_reconstruct(args: argparse.Namespace, progress: Callable[[float, str], None]) -> int:
    t0 = time.perf_counter()
    opts = map_options_from_args(args)
    progress(0.0, "reading")
    mesh = load_disk_mesh(args.mesh, opts.repairs)
    require_interior_vertex(mesh.F, "reconstruct")
    progress(0.15, f"disk map ({args.method})")
    result = disk_map_step(mesh, opts.disk_map)
    progress(0.5, "(H, lambda) and reconstruction")
    hl = curvature_step(mesh, result.uv, opts.curvature)
    rec = reconstruction_step(mesh, result.uv, hl.H, hl.lam, opts.reconstruction)
    progress(0.9, "writing")
    # the input's vertices and faces; removed ears keep their input positions
    write_obj(args.output, rec.X_input, mesh.F_in)
    errors = rec.errors
    result_json = {
        "mesh": str(args.mesh),
        "output": str(args.output),
        "curvature": args.curvature,
        "vertices": int(mesh.V_in.shape[0]),
        "reconstructed_vertices": int(mesh.V.shape[0]),
        **mesh.done,
        **_write_preparation(mesh, args.output),
        "relative_error": errors,
        "map_flipped_triangles": result.info.flipped,
        "reconstruction": rec.info.to_dict(),
        "seconds": time.perf_counter() - t0,
    }
    if args.json:
        print(json.dumps(result_json))
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
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="output .npz: uv (n,2) and faces (m,3) of the input mesh in its order, kept (n,) "
        "bool (False: an ear removed by --remove-ears, placed on the unit circle)",
    )
    p.add_argument(
        "--no-angle-refinement",
        action="store_true",
        help="fast method: return the discrete harmonic map, without the final angle "
        "refinement (which lowers the mean angle distortion, e.g. 1.21° to 1.19°)",
    )
    p.set_defaults(handler=run_map, reconstruct=False)
    p = sub.add_parser("reconstruct", help="map, compute (H, λ), reconstruct by Algorithm 1")
    _add_mesh_options(p)
    p.add_argument(
        "-o",
        "--output",
        required=True,
        help="output OBJ: the input's vertices (in its order) and faces; removed ears keep "
        "their input positions",
    )
    p.add_argument(
        "--curvature",
        choices=["vector", "scalar"],
        default="vector",
        help="represent H as the mean-curvature vector (default, one solve) or the paper's scalar",
    )
    p.add_argument(
        "--no-fold-correction",
        action="store_true",
        help="vector H: keep the linear solve where the disk map folds, instead of solving the "
        "surface's own Laplace equations there (conformorph.geometry.fold_correction)",
    )
    p.set_defaults(handler=run_reconstruct, reconstruct=True)
