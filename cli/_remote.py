"""What the server commands (``submit``, ``batch``) share: server arguments,
request identity, submitting while the server is busy, and fetching a job's
results into a folder."""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from conformorph_client import ApiError

_T = TypeVar("_T")

#: what a morph job's output folder receives
#: landmarks.json: the detected landmarks of a morph with "landmarks": "auto"
MORPH_ARTIFACTS = ("animation.glb", "metrics.json", "landmarks.json")


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


def read_landmarks(path: str | Path, n_meshes: int) -> list[list[Any]]:
    """The landmark file as one list per mesh (the server's own parser: same layouts)."""
    from conformorph.pipelines.landmarks_io import read_landmark_file

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


def submit_when_free(
    create: Callable[[], _T],
    patience: float,
    *,
    also_unavailable: bool = False,
    on_wait: Callable[[ApiError, float], None] | None = None,
) -> _T:
    """``create()``, called again while the server answers 429 (this key's queue is
    full; and 503, no broker, when ``also_unavailable``), for up to ``patience``
    seconds; each pause is the server's ``Retry-After`` (else 5 s), at most 30 s,
    announced to ``on_wait(error, pause)``. After that the error is raised."""
    from conformorph_client import ServiceUnavailable, TooManyJobs

    retried: tuple[type[ApiError], ...] = (
        (TooManyJobs, ServiceUnavailable) if also_unavailable else (TooManyJobs,)
    )
    deadline = time.monotonic() + patience
    while True:
        try:
            return create()
        except retried as exc:
            if time.monotonic() > deadline:
                raise
            wait = exc.retry_after if isinstance(exc, TooManyJobs) else None
            pause = min(30.0, wait or 5.0)
            if on_wait is not None:
                on_wait(exc, pause)
            time.sleep(pause)


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


def download_results(client: Any, job: Any, outdir: Path, per_frame: bool) -> list[Path]:
    """Download a finished job's :func:`wanted_artifacts` into ``outdir`` (created) and
    write its record to ``outdir/job.json``; returns the artifact paths (resolved)."""
    outdir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in wanted_artifacts(job, per_frame):
        dest = safe_artifact_path(outdir, name)
        client.download(job.id, name, dest)
        paths.append(dest)
    (outdir / "job.json").write_text(job.model_dump_json(indent=1) + "\n")
    return paths


def format_job_error(job: Any) -> str:
    err = job.error
    if err is None:
        return f"job {job.id} {job.state}"
    stage = f" in stage {err.stage}" if err.stage else ""
    field = f" (input {err.field})" if err.field else ""
    return f"job {job.id} {job.state}{stage}: {err.type}: {err.message}{field}"
