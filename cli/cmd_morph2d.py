"""``conformorph morph2d``: 2D shape morphing by strain-field interpolation."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from conformorph.cli._output import (
    add_quiet_option,
    check_frames,
    print_json,
    stage_progress,
    use_bars,
)
from conformorph.pipelines.animation_loop import DEFAULT_LOOP, LOOP_MODES

if TYPE_CHECKING:
    from conformorph.pipelines.morph2d import Morph2DOptions

#: Default of ``--max-points`` (kept equal to conformorph.pipelines.shape_io.DEFAULT_MAX_POINTS,
#: which a test checks; not imported so that ``--help`` does not load numpy).
DEFAULT_MAX_POINTS = 2_000
#: Default working resolution on the automatic path (kept equal to
#: conformorph.pipelines.morph2d.correspondence.DEFAULT_POINT_BUDGET, which a test checks).
DEFAULT_POINT_BUDGET = 100


def register(subparsers: Any) -> None:
    """Add the ``morph2d`` command to the CLI's sub-parsers."""
    p = subparsers.add_parser(
        "morph2d",
        help="morph one 2D shape into another (strain-field interpolation)",
        description=(
            "Morph SOURCE into TARGET (shape JSON {'rings': [...]} or SVG path data) using "
            "corresponding anchor points (found automatically without --anchors, or when the "
            'file has fewer than 2 pairs or "partial": true; then written to OUTDIR/anchors.json, '
            "which can be edited and passed back); writes animation.glb, strip.svg, animation.svg, "
            "animation.json (Lottie), frames.json, metrics.json "
            "(and frames/NNN.glb with --per-frame) to OUTDIR."
        ),
        epilog=(
            "Exit status: 0 when the last frame reached the target; 1 when no strain scheme "
            "converged (every output is still written; metrics.json says per frame which "
            "converged); 2 for bad input (nothing computed)."
        ),
    )
    p.add_argument("source", metavar="SOURCE", help="source shape (.json rings or .svg)")
    p.add_argument("target", metavar="TARGET", help="target shape (.json rings or .svg)")
    p.add_argument(
        "--anchors",
        default=None,
        metavar="A.json",
        help='{"anchors": [[[xs, ys], [xt, yt]], ...]} (default: found automatically)',
    )
    p.add_argument(
        "--frames", type=int, default=60, help="frames including source and target (default 60)"
    )
    p.add_argument(
        "--interp",
        choices=["principal", "modified", "linear"],
        default="principal",
        help="strain interpolation: principal (eq. 3 in each triangle's principal frame: "
        "frame independent, default), modified (the paper's eq. 3 in the x/y frame) or "
        "linear (eq. 2); the others are tried when it does not reach the target",
    )
    p.add_argument(
        "--pace",
        choices=["strain", "even"],
        default="strain",
        help="frame k at t = k/(frames-1) of the strain scheme (default, the paper), or the same "
        "path re-timed so that it moves evenly (no snap where eq. 3's shears grow fast near t = 1)",
    )
    p.add_argument("--per-frame", action="store_true", help="also write frames/NNN.glb")
    p.add_argument(
        "--units",
        choices=["px", "pt", "in", "mm", "cm", "m"],
        default="px",
        help="what one SVG user unit is in the GLBs, which are in metres, centred at the "
        "origin, Y up: 'px' (default, CSS pixels at 96 dpi: 0.2646 mm), 'pt', 'in', 'mm', "
        "'cm' or 'm'; the SVG outputs keep SVG units",
    )
    p.add_argument(
        "--size",
        type=float,
        metavar="METRES",
        help="make the GLBs' larger side this many metres instead (all frames together)",
    )
    p.add_argument(
        "--loop",
        choices=list(LOOP_MODES),
        default=DEFAULT_LOOP,
        help=f"how animation.svg plays: once, holding the last frame (default {DEFAULT_LOOP}), "
        "repeat (again and again) or alternate (there and back, again and again)",
    )
    p.add_argument("--texture", metavar="PNG", help="PNG image carried through the morph")
    p.add_argument(
        "--max-points",
        type=int,
        default=DEFAULT_MAX_POINTS,
        metavar="N",
        help=f"refuse a shape with more than N points, all rings together (default {DEFAULT_MAX_POINTS})",
    )
    p.add_argument(
        "--point-budget",
        type=int,
        default=None,
        metavar="N",
        help="working resolution: simplify each shape to at most N points keeping its features "
        f"and the anchors (0: none; default: {DEFAULT_POINT_BUDGET}, or the anchors file's "
        "point_budget; none with a full anchors file on shapes whose rings have equal lengths)",
    )
    for flag, what in (
        ("--max-iterations", "Newton iterations per frame"),
        ("--max-continuation", "largest continuation level N of eq. 12"),
        ("--max-substeps", "time-step halvings when continuation fails"),
    ):
        p.add_argument(
            flag,
            type=int,
            default=None,
            metavar="N",
            help=f"strain solver cap: {what} (default: conformorph.geometry.strain_morph's)",
        )
    p.add_argument(
        "--max-time-step",
        type=float,
        default=None,
        metavar="DT",
        help="largest time step of the strain solver, in (0, 1]: frames further apart get "
        "intermediate warm-start frames (default: conformorph.geometry.strain_morph's, 1/60)",
    )
    p.add_argument("-o", "--outdir", required=True, metavar="OUTDIR", help="output folder")
    p.add_argument("--json", action="store_true", help="print metrics.json to stdout")
    add_quiet_option(p)
    p.set_defaults(handler=run)


def morph2d_options_from_args(args: argparse.Namespace) -> Morph2DOptions:
    """The flags of ``conformorph morph2d`` as pipeline options (the one place they map).

    Raises ValueError for a flag out of range (before anything is read).
    """
    from conformorph.geometry.strain_morph import StrainMorphOptions
    from conformorph.pipelines.morph2d import Morph2DOptions

    check_frames(args.frames)
    if args.max_points < 3:
        raise ValueError(f"--max-points must be at least 3, got {args.max_points}")
    budget = getattr(args, "point_budget", None)
    if budget is not None and budget != 0 and budget < 3:
        raise ValueError(f"--point-budget must be 0 or at least 3, got {budget}")
    caps = {
        k: getattr(args, k)
        for k in ("max_iterations", "max_continuation", "max_substeps")
        if getattr(args, k) is not None
    }
    for k, v in caps.items():
        if v < (0 if k == "max_substeps" else 1):
            raise ValueError(
                f"--{k.replace('_', '-')} must be at least {0 if k == 'max_substeps' else 1}, got {v}"
            )
    if args.max_time_step is not None:
        if not 0.0 < args.max_time_step <= 1.0:
            raise ValueError(f"--max-time-step must be in (0, 1], got {args.max_time_step}")
        caps["max_time_step"] = args.max_time_step
    return Morph2DOptions(
        frames=args.frames,
        interp=args.interp,
        pace=args.pace,
        per_frame=args.per_frame,
        loop=getattr(args, "loop", DEFAULT_LOOP),
        max_points=args.max_points,
        units=getattr(args, "units", None) or "px",
        size=getattr(args, "size", None),
        point_budget=budget,
        solver=StrainMorphOptions(**caps),
    )


def run(args: argparse.Namespace) -> int:
    """Handler of ``conformorph morph2d``."""
    from conformorph.pipelines.morph2d import MorphNotConvergedError, run_morph2d

    options = morph2d_options_from_args(args)
    failure = None
    with stage_progress(use_bars(args.quiet), "morph2d") as bar:
        try:
            result = run_morph2d(
                args.source,
                args.target,
                args.anchors,
                args.outdir,
                options,
                texture_path=args.texture,
                progress=lambda step, total, stage: bar(step / total, stage),
            )
        except MorphNotConvergedError as exc:
            result, failure = exc.metrics, str(exc)
    if args.json:
        print_json(result, indent=2)
    else:
        _print_table(result, args)
    if failure is not None:
        print(f"conformorph morph2d: error: {failure}", file=sys.stderr)
        return 1
    return 0


def _print_parts(result: dict[str, Any], args: argparse.Namespace) -> None:
    """The summary of a morph of shapes of several parts."""
    parts, mesh = result["parts"], result["mesh"]
    separated = sum(p["separated"] for p in parts["pairs"])
    print(
        f"parts: {parts['source_parts']} -> {parts['target_parts']}, "
        f"{len(parts['pairs']) - separated} pair(s) morphed, "
        f"{separated} pair(s) shrunk and grown instead, "
        f"{len(parts['matching']['unmatched_source'])} shrink, "
        f"{len(parts['matching']['unmatched_target'])} grow ({parts['schedule']}); "
        f"mesh {mesh['vertices']} vertices, {mesh['triangles']} triangles"
    )
    strain = result["methods"]["strain"]
    print(
        f"flips {strain['total_flipped']}, overlapping frames {parts['overlapping_frames']}, "
        f"self-crossing frames {parts['self_crossing_frames']}, "
        f"reached target: {'yes' if result['reached_target'] else 'no'}"
    )
    for p in parts["pairs"]:
        if "fallback" in p:
            print(f"part {p['source_part']} -> {p['target_part']}: {p['fallback']}")
    print(
        f"wrote {args.outdir}/animation.glb, strip.svg, animation.svg, frames.json, metrics.json"
        + (", frames/" if args.per_frame else "")
    )


def _print_table(result: dict[str, Any], args: argparse.Namespace) -> None:
    if "parts" in result:
        _print_parts(result, args)
        return
    mesh = result["mesh"]
    print(
        f"mesh: {mesh['vertices']} vertices, {mesh['triangles']} triangles ({mesh['route']}), "
        f"min angle {min(mesh['min_angle_source'], mesh['min_angle_target']):.1f}°"
    )
    for seed in mesh.get("seeded_holes", []):
        x, y = seed["centre"]
        print(
            f"hole {seed['hole']} of the {'target' if seed['side'] == 'source' else 'source'} "
            f"grows from a seed hole of radius {seed['radius']:.3g} at ({x:.4g}, {y:.4g}) "
            f"in the {seed['side']}"
        )
    print(
        f"{'method':<8} {'flips':>5} {'min area':>9} {'max area':>9} {'monotone':>9} "
        f"{'no-squeeze':>10} {'converged':>9} {'s':>7}"
    )
    for name, m in result["methods"].items():
        conv = "-"
        if "frames" in m:
            done = sum(f["converged"] for f in m["frames"])
            conv = "yes" if m["reached_target"] else f"{done}/{len(m['frames'])}"
        print(
            f"{name:<8} {m['total_flipped']:>5d} {m['min_area_ratio']:>9.3f} {m['max_area_ratio']:>9.3f} "
            f"{m['monotone_strain_fraction']:>9.3f} {m['no_squeeze_fraction']:>10.3f} {conv:>9} "
            f"{m['seconds']:>7.3f}"
        )
    chosen = result.get("correspondence", {})
    if chosen.get("source") in ("automatic", "seeded"):
        res = result["working_resolution"]
        print(
            f"anchors: {chosen['pairs']} pairs chosen automatically"
            + (f" from your {chosen['user_pairs']}" if chosen["source"] == "seeded" else "")
            + f" "
            f"(cost {chosen['cost']:.3g}), written to {args.outdir}/anchors.json; "
            f"points {res['source_points'][0]}->{res['source_points'][1]} (source), "
            f"{res['target_points'][0]}->{res['target_points'][1]} (target)"
        )
    used = result["interp_used"]
    if result["interp_fallback"]:
        print(f"strain scheme: {used} (fallback: {result['interp_fallback']})")
    else:
        print(f"strain scheme: {used}")
    print(
        f"wrote {args.outdir}/animation.glb, strip.svg, animation.svg, animation.json, frames.json, metrics.json"
        + (", frames/" if args.per_frame else "")
    )
