"""``conformorph submit``: run a face morph on a conformorph server.

Uploads the meshes, submits the morph (with an ``Idempotency-Key`` derived
from the request, so a retried command does not start a second job), follows
the job with a progress bar showing its current stage, and downloads
``animation.glb`` and ``metrics.json`` (and ``frames/NNN.glb`` with
``--per-frame``) into OUTDIR. A job that fails exits with code 1 and the
server's reason; a request the server refuses exits with code 2 and its reason.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from conformorph.cli._output import (
    FRAME_TIMES_HELP,
    check_frames,
    check_time_flags,
    job_progress,
    parse_frame_times,
    parse_job_vertex_budget,
    parse_times,
    use_bars,
)
from conformorph.cli._remote import (
    add_server_arguments,
    download_results,
    format_job_error,
    read_landmarks,
    request_key,
    submit_when_free,
)
from conformorph.pipelines import job_fields

#: seconds a submission waits for a slot when the server answers 429 (unless --timeout)
BUSY_PATIENCE = 600.0


def register(subparsers: Any) -> None:
    """Add the ``submit`` command."""
    p = subparsers.add_parser(
        "submit",
        help="run a face morph on a server: upload, submit, follow, download",
        description=(
            "Upload key meshes M0 M1 [...] to a conformorph server, start a morph with the "
            "landmark file, show its progress, and download OUTDIR/animation.glb and "
            "OUTDIR/metrics.json."
        ),
    )
    p.add_argument("meshes", nargs="+", metavar="MESH", help="key meshes, at least 2, in order")
    p.add_argument(
        "--landmarks",
        required=True,
        metavar="L.json|auto",
        help="landmark JSON file (same layouts as 'conformorph morph'), or 'auto': the server "
        "detects them (OUTDIR/landmarks.json; a file named auto: ./auto)",
    )
    p.add_argument(
        "--times", type=parse_times, metavar="T0,T1,...", help="key times (server default 0..N)"
    )
    when = p.add_mutually_exclusive_group()
    when.add_argument(
        "--frames", type=int, help="frames from t0 to tN inclusive (server default 30)"
    )
    when.add_argument(
        "--frame-times", type=parse_frame_times, metavar="T,T,...", help=FRAME_TIMES_HELP
    )
    p.add_argument(
        "--method", choices=["dmt", "mt", "identity", "linear"], help="registration (default dmt)"
    )
    p.add_argument(
        "--refine",
        choices=["auto", "guided", "nicp", "static", "none"],
        help="extra DMT correspondences beyond the landmarks (server default auto; see "
        "'conformorph morph --help')",
    )
    p.add_argument(
        "--curvature",
        choices=["screened", "metric", "vector", "scalar"],
        help="curvature homotopy (server default: screened)",
    )
    p.add_argument(
        "--fill-holes",
        action="store_true",
        help="close inner boundary loops with a fan first (as 'conformorph morph')",
    )
    p.add_argument(
        "--remove-ears",
        action="store_true",
        help="remove boundary ear vertices first; landmark ids are translated (as 'conformorph "
        "morph')",
    )
    p.add_argument(
        "--prepare",
        choices=job_fields.PREPARE_CHOICES,
        help="'auto': the server prepares each mesh first (clean-up, largest piece, faired "
        "holes, ears, decimation to the vertex budget; as 'conformorph morph --prepare auto'); "
        f"server default: {job_fields.MORPH_PREPARE_DEFAULT}, as 'conformorph morph'",
    )
    p.add_argument(
        "--vertex-budget",
        type=parse_job_vertex_budget,
        metavar="N",
        help="with --prepare auto: the working resolution, a mesh with more vertices is "
        "decimated to about N on the server; 0 never decimates (as 'conformorph morph'; "
        "server default: the preparation's default budget)",
    )
    p.add_argument(
        "--landmark-fit",
        choices=job_fields.LANDMARK_FIT_CHOICES,
        help="how the landmarks enter the registration (as 'conformorph morph'; server "
        "default: auto, i.e. tolerant with --landmarks auto, exact with a file)",
    )
    p.add_argument("--per-frame", action="store_true", help="also fetch frames/NNN.glb")
    p.add_argument(
        "--normals",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="NORMAL morph deltas where the morph changes the normals (as 'conformorph "
        "morph'; server default: on); --no-normals leaves them out",
    )
    p.add_argument(
        "--baselines",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="also build and measure the MT-only baseline (as 'conformorph morph'; server "
        f"default: {'on' if job_fields.MORPH_BASELINES_DEFAULT else 'off'})",
    )
    p.add_argument(
        "--units",
        choices=["auto", "mm", "cm", "m"],
        help="the meshes' length unit (as 'conformorph morph'; server default: auto)",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="folder for the results")
    p.add_argument(
        "--timeout", type=float, default=None, help="give up after this many seconds of waiting"
    )
    add_server_arguments(p)
    p.set_defaults(handler=run_submit)


# --------------------------------------------------------------------------- submit


def run_submit(args: argparse.Namespace) -> int:
    """Handler of ``conformorph submit``."""
    from conformorph_client import ApiError, Client, TransportError, WaitTimeout

    meshes: Sequence[str] = args.meshes
    if len(meshes) < 2:
        raise ValueError(f"submit needs at least 2 meshes, got {len(meshes)}")
    for m in meshes:
        if not Path(m).is_file():
            raise ValueError(f"no such mesh file: {m}")
    check_frames(args.frames)
    # the ranges the server checks, before anything is uploaded (exit code 2 naming the entry)
    check_time_flags(args.times, args.frame_times, len(meshes))
    landmarks: Any = (
        "auto" if args.landmarks == "auto" else read_landmarks(args.landmarks, len(meshes))
    )
    outdir = Path(args.output)
    bars = use_bars(args.quiet)
    say = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    try:
        with Client(args.server, args.api_key) as c:
            ids = []
            for m in meshes:
                mesh = c.upload_mesh(m)
                say(f"uploaded {m}: mesh {mesh.id} ({mesh.vertices} vertices)")
                ids.append(mesh.id)
            # the request, as create_morph's keywords; with the meshes it also names the
            # request (its idempotency key)
            params: dict[str, Any] = {
                "landmarks": landmarks,
                "times": args.times,
                "frames": args.frames,
                "frame_times": args.frame_times,
                "method": args.method,
                "refine": args.refine,
                "fill_holes": True if args.fill_holes else None,
                "remove_ears": True if args.remove_ears else None,
                "prepare": args.prepare,
                "vertex_budget": args.vertex_budget,
                "landmark_fit": args.landmark_fit,
                "curvature": args.curvature,
                "per_frame": True if args.per_frame else None,
                "normals": args.normals,
                "baselines": args.baselines,
                "units": args.units,
            }
            key = request_key({"meshes": ids, **params})
            job = submit_when_free(
                lambda: c.create_morph(ids, idempotency_key=key, **params),
                args.timeout or BUSY_PATIENCE,
                on_wait=lambda exc, pause: say(
                    f"server busy ({exc.message}); retrying in {pause:.0f} s"
                ),
            )
            say(f"job {job.id} {job.state}")
            with job_progress(bars, "morph") as update:
                job = c.wait(job.id, timeout=args.timeout, on_update=update, raise_on_failure=False)
            if job.state != "succeeded":
                print(f"conformorph submit: {format_job_error(job)}", file=sys.stderr)
                return 1
            download_results(c, job, outdir, args.per_frame)
    except ApiError as exc:
        print(f"conformorph submit: server refused: {exc}", file=sys.stderr)
        return 2 if 400 <= exc.status < 500 else 1
    except (TransportError, WaitTimeout) as exc:
        print(f"conformorph submit: error: {exc}", file=sys.stderr)
        return 1
    seconds = {s.name: s.seconds for s in job.stages}
    total = (job.finished_at or 0) - (job.started_at or job.created_at)
    print(
        f"job {job.id} succeeded in {total:.2f} s "
        + " ".join(f"{k}={v:.2f}s" for k, v in seconds.items() if v is not None)
    )
    print(f"wrote {outdir / 'animation.glb'} and {outdir / 'metrics.json'}")
    return 0
