"""``conformorph morph2d``: 2D shape morphing by strain-field interpolation."""

from __future__ import annotations

import argparse
from typing import Any

from cli._output import check_frames, print_json


def register(subparsers: Any) -> None:
    """Add the ``morph2d`` command to the CLI's sub-parsers."""
    p = subparsers.add_parser(
        "morph2d",
        help="morph one 2D shape into another (strain-field interpolation)",
        description=(
            "Morph SOURCE into TARGET (shape JSON {'rings': [...]} or SVG path data) using "
            "corresponding anchor points; writes animation.glb, strip.svg, metrics.json "
            "(and frames/NNN.glb with --per-frame) to OUTDIR."
        ),
    )
    p.add_argument("source", metavar="SOURCE", help="source shape (.json rings or .svg)")
    p.add_argument("target", metavar="TARGET", help="target shape (.json rings or .svg)")
    p.add_argument(
        "--anchors",
        required=True,
        metavar="A.json",
        help='{"anchors": [[[xs, ys], [xt, yt]], ...]}',
    )
    p.add_argument(
        "--frames", type=int, default=60, help="frames including source and target (default 60)"
    )
    p.add_argument(
        "--interp",
        choices=["modified", "linear"],
        default="modified",
        help="strain interpolation: modified (eq. 3, default) or linear (eq. 2)",
    )
    p.add_argument("--per-frame", action="store_true", help="also write frames/NNN.glb")
    p.add_argument("--texture", metavar="PNG", help="PNG image carried through the morph")
    p.add_argument("-o", "--outdir", required=True, metavar="OUTDIR", help="output folder")
    p.add_argument("--json", action="store_true", help="print metrics.json to stdout")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``conformorph morph2d``."""
    from worker.morph2d_pipeline import run_morph2d

    check_frames(args.frames)
    result = run_morph2d(
        args.source,
        args.target,
        args.anchors,
        args.outdir,
        frames=args.frames,
        interp=args.interp,
        per_frame=args.per_frame,
        texture_path=args.texture,
    )
    if args.json:
        print_json(result, indent=2)
        return 0
    mesh = result["mesh"]
    print(
        f"mesh: {mesh['vertices']} vertices, {mesh['triangles']} triangles ({mesh['route']}), "
        f"min angle {min(mesh['min_angle_source'], mesh['min_angle_target']):.1f}°"
    )
    print(
        f"{'method':<8} {'flips':>5} {'min area':>9} {'max area':>9} {'monotone':>9} {'no-squeeze':>10} {'s':>7}"
    )
    for name, m in result["methods"].items():
        print(
            f"{name:<8} {m['total_flipped']:>5d} {m['min_area_ratio']:>9.3f} {m['max_area_ratio']:>9.3f} "
            f"{m['monotone_strain_fraction']:>9.3f} {m['no_squeeze_fraction']:>10.3f} {m['seconds']:>7.3f}"
        )
    print(
        f"wrote {args.outdir}/animation.glb, strip.svg, metrics.json"
        + (", frames/" if args.per_frame else "")
    )
    return 0
