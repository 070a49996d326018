"""``conformorph morph``: conformal face morphing between two or more meshes with landmarks."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from conformorph.cli._output import (
    FRAME_TIMES_HELP,
    add_cache_options,
    add_quiet_option,
    add_vertex_budget_option,
    cache_dir_from_args,
    check_frames,
    check_time_flags,
    parse_frame_times,
    parse_times,
    print_json,
    stage_progress,
    use_bars,
)
from conformorph.pipelines import job_fields


def register(subparsers: Any) -> None:
    """Add the ``morph`` command."""
    p = subparsers.add_parser(
        "morph",
        help="morph face meshes (MT/DMT registration on the disk, cubic-spline homotopy)",
        description=(
            "Morph key meshes M0 M1 [M2 ...] (disk topology, any connectivity) using landmarks: "
            "disk conformal maps, registration by MT or DMT, consistent mesh, cubic-spline "
            "homotopy of (disk position, curvature, conformal factor), reconstruction of every "
            "frame. Writes OUTDIR/animation.glb (morph targets + weights animation + rigid TRS), "
            "OUTDIR/metrics.json, and with --per-frame OUTDIR/frames/NNN.glb."
        ),
    )
    p.add_argument(
        "meshes", nargs="+", metavar="MESH", help="key meshes, at least 2, in time order"
    )
    p.add_argument(
        "--landmarks",
        required=True,
        metavar="L.json|auto",
        help="landmark JSON file, or 'auto': detect the 68 Multi-PIE landmarks on every mesh "
        "(needs mediapipe, see the README), write them to OUTDIR/landmarks.json (the same "
        "format, with confidences and warnings; edit and pass it back) and morph with them "
        "(a file named auto: ./auto). A file may name its points by 0-based ibug index "
        '("indices": [17, ..., 67]) and ask for the missing ones of the 68 to be detected '
        '("fill": "auto")',
    )
    p.add_argument(
        "--times", type=parse_times, metavar="T0,T1,...", help="key times (default 0,1,...,N)"
    )
    when = p.add_mutually_exclusive_group()
    when.add_argument(
        "--frames", type=int, default=30, help="frames from t0 to tN inclusive (default 30)"
    )
    when.add_argument(
        "--frame-times",
        type=parse_frame_times,
        metavar="T,T,...",
        help=FRAME_TIMES_HELP,
    )
    p.add_argument(
        "--method",
        choices=["dmt", "mt", "identity", "linear"],
        default="dmt",
        help="registration for the homotopy; identity needs shared faces; linear = linear "
        "vertex interpolation on the DMT-registered consistent mesh (default dmt)",
    )
    p.add_argument(
        "--curvature",
        choices=["screened", "metric", "vector", "scalar"],
        default="screened",
        help="curvature homotopy: 'metric' (mean-curvature vector on the interpolated metric's "
        "Laplacian) screened towards the cubic spline of the key positions (default, measured "
        "best), 'metric' alone, mean-curvature vector on the disk Laplacian, or the paper's "
        "scalar H with Algorithm 1",
    )
    p.add_argument(
        "--consistent-mesh",
        choices=["source", "landmarks"],
        default="source",
        help="consistent mesh: the first mesh itself (default) or the refined landmark mesh",
    )
    p.add_argument(
        "--texture", nargs="+", metavar="IMG", help="one texture image per mesh (needs UVs)"
    )
    p.add_argument(
        "--refine",
        choices=["auto", "nicp", "guided", "static", "none"],
        default="auto",
        help="extra DMT correspondences beyond the landmarks: 'auto' (default) is nicp on "
        "consistent meshes of at most 20,000 nodes and guided above; 'nicp' dense ones from a "
        "non-rigid ICP (closest to the oracle registration, about 0.6 s a pair of 7k-vertex "
        "faces, far more on large meshes), 'guided' deformation-guided closest points, "
        "'static' closest points where the surfaces coincide, 'none' the paper's DMT",
    )
    p.add_argument(
        "--landmark-fit",
        choices=job_fields.LANDMARK_FIT_CHOICES,
        default=job_fields.LANDMARK_FIT_DEFAULT,
        help="how the registration treats the landmarks: 'exact' the paper's DMT "
        "interpolates them; 'tolerant' weights them by the landmark file's confidence, smooths "
        "them and lets the non-rigid ICP correct them (imprecise landmarks: few, or detected); "
        "'auto' (default) is 'tolerant' with --landmarks auto and 'exact' with a file",
    )
    p.add_argument(
        "--consistency-check",
        action="store_true",
        help="also register every pair backwards and report in metrics.json "
        "(registration.correspondence_estimate) how far the forward-then-backward map "
        "moves each consistent node: an estimate of the per-vertex correspondence error "
        "(costs a second registration of every pair)",
    )
    p.add_argument(
        "--remove-ears",
        action="store_true",
        help="remove boundary vertices that lie in a single triangle first (landmark ids are "
        "translated)",
    )
    p.add_argument(
        "--fill-holes",
        action="store_true",
        help="close inner boundary loops (eyes, mouth) with a fan first; input vertex ids "
        "are kept, hole centres appended",
    )
    p.add_argument(
        "--prepare",
        choices=job_fields.PREPARE_CHOICES,
        default=job_fields.MORPH_PREPARE_DEFAULT,
        help="'auto' (default): prepare each mesh first (drop unreferenced vertices, degenerate "
        "and duplicate faces, fragments; repair non-manifold spots; fill holes with faired "
        "patches; remove ears): a clean disk is left as read, otherwise what changed is in "
        "metrics.json (inputs[i].preparation) and the vertex maps in OUTDIR/preparation.json; "
        "'none': the meshes as read",
    )
    add_vertex_budget_option(p)
    add_cache_options(p)
    add_units_option(p)
    add_output_options(p)
    add_quiet_option(p)
    p.set_defaults(handler=run_morph)


def add_units_option(p: argparse.ArgumentParser) -> None:
    """``--units``: the keys' length unit (one default, :data:`DEFAULT_UNITS`)."""
    from conformorph.pipelines.face_morph.units import DEFAULT_UNITS, UNIT_CHOICES

    p.add_argument(
        "--units",
        choices=UNIT_CHOICES,
        default=DEFAULT_UNITS,
        help="the meshes' length unit; 'auto' (default) infers each mesh's: from its outer "
        "eye corners (landmarks 36 and 45, 8.5-10 cm apart on adults) when it has the 68 "
        "landmarks, else from its size (a face about 20 cm across). The meshes are brought "
        "to one scale before the morph, the GLBs are written in metres, and metrics.json "
        "says each mesh's units, how they were found and the factor applied",
    )


def add_output_options(p: argparse.ArgumentParser) -> None:
    """The flags of what ``conformorph morph`` writes: per-frame GLBs, normals, metrics,
    baselines, the output folder and ``--json``."""
    from conformorph.pipelines.face_morph.options import DEFAULT_NORMALS
    from conformorph.pipelines.gltf_compression import COMPRESS_CHOICES, DEFAULT_COMPRESS

    p.add_argument("--per-frame", action="store_true", help="also write frames/NNN.glb")
    p.add_argument(
        "--normals",
        action=argparse.BooleanOptionalAction,
        default=DEFAULT_NORMALS,
        help="write NORMAL morph deltas where the morph changes the normals (default on, so "
        "three.js and Babylon light an opening mouth right; Blender ignores them); "
        "--no-normals leaves them out (about a third of animation.glb)",
    )
    p.add_argument(
        "--compress",
        choices=COMPRESS_CHOICES,
        default=DEFAULT_COMPRESS,
        help="EXT_meshopt_compression of the GLBs, animation.glb's morph targets quantized "
        "(KHR_mesh_quantization, within 1e-4 of the diagonal; three.js and Babylon decode "
        "both): 'auto' (default) when a file would exceed 16 MiB, 'meshopt' always, 'none' "
        "(plain float) for tools without a meshopt decoder (Blender, trimesh)",
    )
    p.add_argument(
        "--output-resolution",
        choices=["auto", "input", "working"],
        default="auto",
        help="'input': when the first mesh was decimated to the working resolution "
        "(--vertex-budget), the GLBs carry it as read, following the morph with its detail; "
        "'working': the decimated mesh the morph was computed on; 'auto' (default): input up "
        "to 300,000 vertices (a 273k-vertex pair: 28 s, 1.8 GB, 57 MB against 12 s, 0.5 GB, "
        "12 MB), working above",
    )
    p.add_argument("--no-metrics", action="store_true", help="skip the key-frame error metrics")
    p.add_argument(
        "--baselines",
        action=argparse.BooleanOptionalAction,
        default=job_fields.MORPH_BASELINES_DEFAULT,
        help="also build the MT-only baseline and measure its key frames (metrics.json "
        "frames.key_frame_L2_to_inputs.mt, registration.composite_folded_triangles.mt); off "
        "by default, which saves about a third of a second on two 7k-vertex faces",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="output folder")
    p.add_argument("--json", action="store_true", help="print the metrics as one JSON object")


def morph_options_from_args(args: argparse.Namespace) -> Any:
    """The :class:`conformorph.pipelines.face_morph.FaceMorphOptions` of ``conformorph morph``'s flags."""
    from conformorph.pipelines.face_morph import (
        ExportOptions,
        FaceMorphOptions,
        FrameOptions,
        KeyOptions,
        RegistrationOptions,
        resolve_landmark_fit,
    )

    return FaceMorphOptions(
        times=None if args.times is None else tuple(args.times),
        frames=args.frames,
        frame_times=None if args.frame_times is None else tuple(args.frame_times),
        keys=KeyOptions(
            fill_holes=args.fill_holes,
            remove_ears=args.remove_ears,
            prepare=args.prepare,
            vertex_budget=args.vertex_budget,
        ),
        registration=RegistrationOptions(
            method=args.method,
            consistent=args.consistent_mesh,
            refine=args.refine,
            landmark_fit=resolve_landmark_fit(args.landmark_fit, _detects_landmarks(args)),
            baselines=args.baselines,
            consistency_check=getattr(args, "consistency_check", False),
        ),
        homotopy=FrameOptions(curvature=args.curvature, key_metrics=not args.no_metrics),
        export=ExportOptions(
            per_frame=args.per_frame,
            normals=args.normals,
            compress=getattr(args, "compress", None) or "auto",
            output_resolution=getattr(args, "output_resolution", None) or "auto",
        ),
        units=args.units,
        # big keys in spawned processes: the console script's __main__ is guarded
        key_processes=True,
        key_cache=cache_dir_from_args(args),
    )


def _detects_landmarks(args: argparse.Namespace) -> bool:
    """``--landmarks auto``, or a landmark file asking for ``"fill": "auto"``."""
    from conformorph.pipelines.landmark_document import requests_fill

    landmarks = getattr(args, "landmarks", None)
    return landmarks == "auto" or (landmarks is not None and requests_fill(landmarks))


def run_morph(args: argparse.Namespace) -> int:
    """Handler of ``conformorph morph``."""
    from conformorph.pipelines.face_morph import run_face_morph

    if len(args.meshes) < 2:
        raise ValueError(f"morph needs at least 2 meshes, got {len(args.meshes)}")
    check_frames(args.frames)
    # the ranges the API, the client and batch manifests share (exit code 2 naming the entry)
    check_time_flags(args.times, args.frame_times, len(args.meshes))
    options = morph_options_from_args(args)
    with stage_progress(use_bars(args.quiet), "morph") as progress:
        if _detects_landmarks(args):
            from conformorph.pipelines.face_morph.auto_landmarks import run_face_morph_auto

            metrics = run_face_morph_auto(
                args.meshes,
                args.output,
                options,
                textures=args.texture,
                progress=progress,
                given=None if args.landmarks == "auto" else args.landmarks,
            )
        else:
            metrics = run_face_morph(
                args.meshes,
                args.landmarks,
                args.output,
                options,
                textures=args.texture,
                progress=progress,
            )
    for w in metrics.get("landmarks", {}).get("warnings", []):
        print(f"warning: landmarks: {w}", file=sys.stderr)
    bij = metrics["bijectivity"]
    for fb in bij["fallbacks"]:  # on stderr even with --json, whose stdout is the metrics
        a, b = fb["pair"]
        print(f"warning: meshes {a} -> {b}: {fb['message']}", file=sys.stderr)
    if args.json:
        print_json(metrics)
    else:
        s = metrics["seconds"]
        jac = bij["min_jacobian"]
        print(
            f"wrote {args.output}/animation.glb ({len(metrics['frame_times'])} frames, "
            f"method {args.method}; {bij['folded_triangles']} folded triangles"
            + ("" if jac is None else f", min Jacobian {jac:.3g}")
            + (f", {len(bij['fallbacks'])} DMT fallback(s)" if bij["fallbacks"] else "")
            + f") in {s['total']:.2f} s"
        )
    return 0
