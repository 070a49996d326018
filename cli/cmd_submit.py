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
import hashlib
import json
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

#: seconds a submission waits for a slot when the server answers 429 (unless --timeout)
BUSY_PATIENCE = 600.0
#: what a morph job's output folder receives
MORPH_ARTIFACTS = ("animation.glb", "metrics.json")


def parse_times(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(
            f"--times must be comma-separated numbers: {text!r}"
        ) from exc


def add_server_arguments(p: argparse.ArgumentParser) -> None:
    """``--server``, ``--api-key``, ``--quiet`` (shared by submit and batch)."""
    p.add_argument(
        "--server",
        default=os.environ.get("CONFORMORPH_SERVER"),
        required="CONFORMORPH_SERVER" not in os.environ,
        metavar="URL",
        help="the server, e.g. http://127.0.0.1:8000 (default $CONFORMORPH_SERVER)",
    )
    p.add_argument(
        "--api-key",
        default=os.environ.get("CONFORMORPH_API_KEY"),
        metavar="KEY",
        help="API key, sent as a Bearer token (default $CONFORMORPH_API_KEY; none: an open server)",
    )
    p.add_argument(
        "-q", "--quiet", action="store_true", help="no progress bars (also off when not a terminal)"
    )


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
        metavar="L.json",
        help="landmark JSON file (same layouts as 'conformorph morph')",
    )
    p.add_argument(
        "--times", type=parse_times, metavar="T0,T1,...", help="key times (server default 0..N)"
    )
    p.add_argument("--frames", type=int, help="frames from t0 to tN inclusive (server default 30)")
    p.add_argument(
        "--method", choices=["dmt", "mt", "identity", "linear"], help="registration (default dmt)"
    )
    p.add_argument("--curvature", choices=["vector", "scalar"], help="curvature homotopy")
    p.add_argument("--per-frame", action="store_true", help="also fetch frames/NNN.glb")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="folder for the results")
    p.add_argument(
        "--timeout", type=float, default=None, help="give up after this many seconds of waiting"
    )
    add_server_arguments(p)
    p.set_defaults(handler=run_submit)


# --------------------------------------------------------------------------- shared helpers


def read_landmarks(path: str | Path, n_meshes: int) -> list[list[Any]]:
    """The landmark file as one list per mesh (the server's own parser: same layouts)."""
    from worker.landmarks_io import read_landmark_file

    return read_landmark_file(path, n_meshes)


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def request_key(body: dict[str, Any]) -> str:
    """A stable Idempotency-Key for a request body."""
    canon = json.dumps(body, sort_keys=True, separators=(",", ":"))
    return "cm-" + hashlib.sha256(canon.encode()).hexdigest()[:40]


def wanted_artifacts(job: Any, per_frame: bool) -> list[str]:
    """Artifacts to fetch: a morph's GLB and metrics (+ frames); everything for other kinds."""
    names = [a.name for a in job.artifacts]
    if job.kind != "morph":
        return names
    out = [n for n in MORPH_ARTIFACTS if n in names]
    if per_frame:
        out += sorted(n for n in names if n.startswith("frames/"))
    return out


def safe_artifact_path(outdir: Path, name: str) -> Path:
    """OUTDIR/name, refusing names that would leave OUTDIR."""
    dest = (outdir / name).resolve()
    if outdir.resolve() not in dest.parents:
        raise ValueError(f"artifact name {name!r} leaves the output folder")
    return dest


def use_bars(quiet: bool) -> bool:
    return not quiet and sys.stderr.isatty()


def stage_text(job: Any) -> str:
    """``state stage (k/n)``: the job's state and current stage, by its place in the stages."""
    names = [s.name for s in job.stages]
    if job.stage in names:
        return f"{job.state} {job.stage} ({names.index(job.stage) + 1}/{len(names)})"
    return f"{job.state} (0/{len(names)})"


@contextmanager
def job_progress(enabled: bool, label: str) -> Iterator[Callable[[Any], None]]:
    """A rich progress bar fed with job records; a no-op when disabled."""
    if not enabled:
        yield lambda job: None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    with Progress(
        TextColumn("{task.fields[label]}"),
        BarColumn(),
        TaskProgressColumn(),
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
    ) as progress:
        task = progress.add_task("queued", total=1.0, label=label)

        def update(job: Any) -> None:
            progress.update(task, completed=job.progress, description=stage_text(job))

        yield update


def format_job_error(job: Any) -> str:
    err = job.error
    if err is None:
        return f"job {job.id} {job.state}"
    stage = f" in stage {err.stage}" if err.stage else ""
    field = f" (input {err.field})" if err.field else ""
    return f"job {job.id} {job.state}{stage}: {err.type}: {err.message}{field}"


# --------------------------------------------------------------------------- submit


def run_submit(args: argparse.Namespace) -> int:
    """Handler of ``conformorph submit``."""
    from conformorph_client import ApiError, Client, TooManyJobs, TransportError, WaitTimeout

    meshes: Sequence[str] = args.meshes
    if len(meshes) < 2:
        raise ValueError(f"submit needs at least 2 meshes, got {len(meshes)}")
    for m in meshes:
        if not Path(m).is_file():
            raise ValueError(f"no such mesh file: {m}")
    if args.frames is not None and args.frames < 2:
        raise ValueError(f"--frames must be at least 2, got {args.frames}")
    landmarks = read_landmarks(args.landmarks, len(meshes))
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
            body: dict[str, Any] = {
                "meshes": ids,
                "landmarks": landmarks,
                "times": args.times,
                "frames": args.frames,
                "method": args.method,
                "curvature": args.curvature,
                "per_frame": True if args.per_frame else None,
            }
            patience = time.monotonic() + (args.timeout or BUSY_PATIENCE)
            while True:
                try:
                    job = c.create_morph(
                        ids,
                        landmarks=landmarks,
                        times=args.times,
                        frames=args.frames,
                        method=args.method,
                        curvature=args.curvature,
                        per_frame=body["per_frame"],
                        idempotency_key=request_key(body),
                    )
                    break
                except TooManyJobs as exc:  # this key's queue is full: wait for a slot
                    if time.monotonic() > patience:
                        raise
                    pause = min(30.0, exc.retry_after or 5.0)
                    say(f"server busy ({exc.message}); retrying in {pause:.0f} s")
                    time.sleep(pause)
            say(f"job {job.id} {job.state}")
            with job_progress(bars, "morph") as update:
                job = c.wait(job.id, timeout=args.timeout, on_update=update, raise_on_failure=False)
            if job.state != "succeeded":
                print(f"conformorph submit: {format_job_error(job)}", file=sys.stderr)
                return 1
            outdir.mkdir(parents=True, exist_ok=True)
            for name in wanted_artifacts(job, args.per_frame):
                c.download(job.id, name, safe_artifact_path(outdir, name))
            (outdir / "job.json").write_text(job.model_dump_json(indent=1) + "\n")
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
