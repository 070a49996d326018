"""``conformorph batch``: many morphs on a server, resumable.

The manifest (JSON or YAML) lists jobs::

    {"jobs": [{"name": "smile", "meshes": ["a.obj", "b.obj"], "landmarks": "L.json",
               "frames": 30, "method": "dmt", "times": [0, 1]}, ...]}

Paths are relative to the manifest's folder; ``"landmarks": "auto"`` has the server
detect them (the job's ``landmarks.json`` lands beside its outputs). A job may also say
``"kind": "conformal_map"`` or ``"reconstruction"`` with one mesh, or
``"kind": "morph2d"`` with ``"shapes": [source, target]`` (JSON rings or SVG)
and optionally ``"anchors"`` (an anchors file, as ``conformorph morph2d --anchors``;
absent, the anchors are found automatically).
Every other key of a job is an option of its API request, under the API's own
name (the client method's keyword); the keys each kind takes are listed once,
in ``_MORPH_KEYS``, ``_MORPH2D_KEYS`` and ``_SINGLE_KEYS``. Each job's results
go to ``OUTDIR/NAME/``.

Resuming: ``OUTDIR/.conformorph-batch.json`` records every upload (by the
file's SHA-256) and every submitted job, written atomically after each
change. A re-run uploads no file twice, skips jobs already finished (their
outputs still present), follows jobs that were submitted but not finished,
and submits the rest. Submissions carry an ``Idempotency-Key`` derived from
the job's content, so a job submitted just before an interruption is found
again, not started twice. Jobs that failed on the server are reported again
without being resubmitted unless ``--retry-failed``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from conformorph.cli._output import job_bars, stage_text, use_bars
from conformorph.cli._remote import (
    add_server_arguments,
    download_results,
    file_sha256,
    format_job_error,
    read_landmarks,
    request_key,
    submit_when_free,
)

STATE_FILE = ".conformorph-batch.json"
STATE_VERSION = 1
KINDS = ("morph", "conformal_map", "reconstruction", "morph2d")
#: seconds a submission waits out "too many jobs" (429) or "no broker" (503) answers
SUBMIT_PATIENCE = 600.0
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,99}$")
_CALLBACK_KEYS = {"callback_url", "callback_secret"}
_REPAIR_KEYS = {"fill_holes", "remove_ears", "prepare", "vertex_budget"} | _CALLBACK_KEYS
_MORPH_KEYS = {
    "times",
    "frames",
    "frame_times",
    "method",
    "refine",
    "landmark_fit",
    "curvature",
    "consistent",
    "per_frame",
    "normals",
    "baselines",
    "units",
    "compress",
    "output_resolution",
} | _REPAIR_KEYS
_MORPH2D_KEYS = {
    "frames",
    "interp",
    "pace",
    "loop",
    "per_frame",
    "point_budget",
    "units",
    "size",
} | _CALLBACK_KEYS
_SINGLE_KEYS = {
    "conformal_map": {"method", "center_vertex", "angle_vertex", "refine_angles"} | _REPAIR_KEYS,
    "reconstruction": {"method", "curvature", "fold_correction"} | _REPAIR_KEYS,
}


def register(subparsers: Any) -> None:
    """Add the ``batch`` command."""
    p = subparsers.add_parser(
        "batch",
        help="run a manifest of morphs on a server (resumable)",
        description=(
            'Run every job of MANIFEST ({"jobs": [{"name", "meshes", "landmarks", "frames", '
            '"method", ...}]}, JSON or YAML; also "kind": "conformal_map", "reconstruction" '
            'or "morph2d" with "shapes" and "anchors") on a server; results in OUTDIR/NAME/. '
            "A re-run skips finished jobs and uploads nothing twice."
        ),
    )
    p.add_argument("manifest", metavar="MANIFEST", help="manifest .json, .yaml or .yml")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="results folder")
    p.add_argument(
        "--parallel", type=int, default=2, metavar="N", help="jobs in flight at once (default 2)"
    )
    p.add_argument(
        "--retry-failed", action="store_true", help="resubmit jobs that failed on the server"
    )
    p.add_argument(
        "--timeout", type=float, default=None, help="seconds to wait for each job (default none)"
    )
    add_server_arguments(p)
    p.set_defaults(handler=run_batch)


# --------------------------------------------------------------------------- manifest


@dataclass(frozen=True)
class JobSpec:
    """One manifest entry, with paths resolved and landmarks read."""

    name: str
    kind: str
    #: the input files: meshes, or a morph2d's source and target shapes
    meshes: tuple[Path, ...]
    params: dict[str, Any]
    #: read from the manifest's file, or "auto" (detected by the server)
    landmarks: list[list[Any]] | str | None
    #: a morph2d's anchors, [[[xs, ys], [xt, yt]], ...]
    anchors: list[list[list[float]]] | None = None


def load_manifest(path: str | Path) -> list[JobSpec]:
    """Read and check a manifest; raises ValueError naming the problem."""
    p = Path(path)
    text = p.read_text()
    if p.suffix.lower() in (".yaml", ".yml"):
        import yaml

        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ValueError(f"{p}: not valid YAML: {exc}") from exc
    else:
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{p}: not valid JSON: {exc}") from exc
    if not isinstance(data, dict) or not isinstance(data.get("jobs"), list) or not data["jobs"]:
        raise ValueError(f'{p}: expected {{"jobs": [...]}} with at least one job')
    base = p.resolve().parent
    specs: list[JobSpec] = []
    seen: set[str] = set()
    for i, job in enumerate(data["jobs"]):
        where = f"{p}: jobs[{i}]"
        if not isinstance(job, dict):
            raise ValueError(f"{where}: must be an object")
        name = job.get("name")
        if not isinstance(name, str) or not _NAME_RE.match(name):
            raise ValueError(
                f"{where}: 'name' must be letters, digits, '.', '_' or '-' (got {name!r})"
            )
        if name in seen:
            raise ValueError(f"{where}: duplicate name {name!r}")
        seen.add(name)
        kind = job.get("kind", "morph")
        if kind not in KINDS:
            raise ValueError(f"{where}: unknown kind {kind!r}; expected one of {', '.join(KINDS)}")
        if kind == "morph2d":
            specs.append(_morph2d_spec(job, where, base, name))
            continue
        meshes = job.get("meshes")
        if not isinstance(meshes, list) or not all(isinstance(m, str) for m in meshes):
            raise ValueError(f"{where}: 'meshes' must be a list of file paths")
        paths = _existing_files(base, meshes, "mesh", where)
        allowed = _MORPH_KEYS if kind == "morph" else _SINGLE_KEYS[kind]
        extra = set(job) - allowed - {"name", "kind", "meshes", "landmarks"}
        if extra:
            raise ValueError(f"{where}: unknown keys {sorted(extra)} for a {kind} job")
        params = {k: job[k] for k in allowed if job.get(k) is not None}
        landmarks: list[list[Any]] | str | None = None
        if kind == "morph":
            if len(paths) < 2:
                raise ValueError(f"{where}: a morph needs at least 2 meshes")
            _check_times(job, len(paths), where)
            if not isinstance(job.get("landmarks"), str):
                raise ValueError(f"{where}: 'landmarks' must be a file path or \"auto\"")
            if job["landmarks"] == "auto":  # detected on the server (a file named auto: ./auto)
                landmarks = "auto"
            else:
                try:
                    landmarks = read_landmarks(base / job["landmarks"], len(paths))
                except (ValueError, OSError) as exc:
                    raise ValueError(f"{where}: {exc}") from exc
        elif len(paths) != 1:
            raise ValueError(f"{where}: a {kind} job takes exactly one mesh")
        specs.append(JobSpec(name, kind, paths, params, landmarks))
    return specs


def _check_times(job: dict[str, Any], n_keys: int, where: str) -> None:
    """A morph entry's ``times`` and ``frame_times`` against the ranges the server checks
    (:mod:`conformorph.pipelines.job_fields`); ValueError naming the job and the entry."""
    from conformorph.pipelines.job_fields import check_morph_times

    lists = {}
    for key in ("times", "frame_times"):
        value = job.get(key)
        if value is not None and not (
            isinstance(value, list)
            and all(isinstance(t, int | float) and not isinstance(t, bool) for t in value)
        ):
            raise ValueError(f"{where}: '{key}' must be a list of numbers")
        lists[key] = value
    try:
        check_morph_times(lists["times"], lists["frame_times"], n_keys)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from exc


def _existing_files(base: Path, names: list[str], what: str, where: str) -> tuple[Path, ...]:
    """The manifest's relative paths resolved; ValueError naming the first missing file."""
    paths = tuple((base / n).resolve() for n in names)
    for path in paths:
        if not path.is_file():
            raise ValueError(f"{where}: no such {what} file: {path}")
    return paths


def _morph2d_spec(job: dict[str, Any], where: str, base: Path, name: str) -> JobSpec:
    """A ``"kind": "morph2d"`` entry: two shape files and, optionally, an anchors file
    (absent or with fewer than 2 pairs: the anchors are found automatically)."""
    from conformorph.pipelines.shape_io import read_anchors

    extra = set(job) - _MORPH2D_KEYS - {"name", "kind", "shapes", "anchors"}
    if extra:
        raise ValueError(f"{where}: unknown keys {sorted(extra)} for a morph2d job")
    shapes = job.get("shapes")
    if not (
        isinstance(shapes, list) and len(shapes) == 2 and all(isinstance(s, str) for s in shapes)
    ):
        raise ValueError(f"{where}: 'shapes' must be [source, target] file paths")
    paths = _existing_files(base, shapes, "shape", where)
    anchors = None  # absent: found automatically by the worker
    if "anchors" in job:
        if not isinstance(job["anchors"], str):
            raise ValueError(f"{where}: 'anchors' must be a file path")
        try:
            anchors = read_anchors(base / job["anchors"], min_pairs=0).tolist()
        except (ValueError, OSError) as exc:
            raise ValueError(f"{where}: {exc}") from exc
    params = {k: job[k] for k in _MORPH2D_KEYS if job.get(k) is not None}
    return JobSpec(name, "morph2d", paths, params, None, anchors)


# --------------------------------------------------------------------------- state


class BatchState:
    """The resumable record in ``OUTDIR/.conformorph-batch.json`` (thread-safe)."""

    def __init__(self, outdir: Path, server: str) -> None:
        self.path = outdir / STATE_FILE
        self.lock = threading.RLock()
        self.data: dict[str, Any] = {"version": STATE_VERSION, "uploads": {}, "jobs": {}}
        if self.path.exists():
            try:
                loaded = json.loads(self.path.read_text())
            except json.JSONDecodeError as exc:
                raise ValueError(f"{self.path}: corrupt state file ({exc}); remove it") from exc
            if loaded.get("version") == STATE_VERSION:
                self.data = loaded
        if self.data.get("server") not in (None, server):
            # ids belong to a server: another server means starting over
            self.data = {"version": STATE_VERSION, "uploads": {}, "jobs": {}}
        self.data["server"] = server
        self.upload_locks: dict[str, threading.Lock] = {}

    def save(self) -> None:
        with self.lock:
            tmp = self.path.with_name(self.path.name + ".tmp")
            tmp.write_text(json.dumps(self.data, indent=1, sort_keys=True) + "\n")
            os.replace(tmp, self.path)

    def upload_id(self, digest: str) -> str | None:
        with self.lock:
            rec = self.data["uploads"].get(digest)
            return None if rec is None else str(rec["id"])

    def set_upload(self, digest: str, mesh_id: str, path: Path) -> None:
        with self.lock:
            self.data["uploads"][digest] = {"id": mesh_id, "file": str(path)}
            self.save()

    def forget_uploads(self) -> None:
        with self.lock:
            self.data["uploads"] = {}
            self.save()

    def lock_for(self, digest: str) -> threading.Lock:
        with self.lock:
            return self.upload_locks.setdefault(digest, threading.Lock())

    def job(self, name: str) -> dict[str, Any]:
        with self.lock:
            return dict(self.data["jobs"].get(name, {}))

    def set_job(self, name: str, **fields: Any) -> None:
        with self.lock:
            self.data["jobs"].setdefault(name, {}).update(fields)
            self.save()


# --------------------------------------------------------------------------- running


@dataclass
class Outcome:
    name: str
    status: str  # done | skipped | failed
    job_id: str | None = None
    seconds: float | None = None
    detail: str = ""
    uploads: int = 0


def fingerprint(spec: JobSpec, digests: list[str]) -> str:
    """Identity of a job's request: kind, file contents, landmarks and parameters."""
    return request_key(
        {
            "kind": spec.kind,
            "meshes": digests,
            "landmarks": spec.landmarks,
            "params": spec.params,
            **({"anchors": spec.anchors} if spec.anchors is not None else {}),
        }
    )


def _outputs_present(outdir: Path, rec: dict[str, Any]) -> bool:
    files = rec.get("files") or []
    return bool(files) and all((outdir / f).is_file() for f in files)


class Runner:
    def __init__(self, client: Any, state: BatchState, outdir: Path, args: argparse.Namespace):
        self.c, self.state, self.outdir, self.args = client, state, outdir, args
        self.progress: Any = None
        self.overall: Any = None

    def _upload(self, path: Path, digest: str, shape: bool = False) -> tuple[str, bool]:
        # a shape and a mesh are different uploads even of the same bytes
        key = f"shape:{digest}" if shape else digest
        with self.state.lock_for(key):
            known = self.state.upload_id(key)
            if known is not None:
                return known, False
            item = self.c.upload_shape(path) if shape else self.c.upload_mesh(path)
            self.state.set_upload(key, item.id, path)
            return item.id, True

    def _upload_all(self, spec: JobSpec, digests: list[str]) -> tuple[list[str], int]:
        """The inputs' ids (uploading those not recorded) and how many were sent."""
        ids, sent = [], 0
        for m, d in zip(spec.meshes, digests, strict=True):
            mid, new = self._upload(m, d, shape=spec.kind == "morph2d")
            sent += new
            ids.append(mid)
        return ids, sent

    def _submit(self, spec: JobSpec, ids: list[str], key: str) -> Any:
        """Submit, waiting out 429 (this key's queue is full) and 503 (no broker)."""
        return submit_when_free(
            lambda: self._submit_once(spec, ids, key), SUBMIT_PATIENCE, also_unavailable=True
        )

    def _wait(self, job_id: str, update: Any) -> Any:
        """Follow a job, riding out a few broken connections (the job runs on regardless)."""
        from conformorph_client import TransportError

        for attempt in range(4):
            try:
                return self.c.wait(
                    job_id, timeout=self.args.timeout, on_update=update, raise_on_failure=False
                )
            except TransportError:
                if attempt == 3:
                    raise
                time.sleep(2.0 * (attempt + 1))
        raise AssertionError("unreachable")

    def _submit_once(self, spec: JobSpec, ids: list[str], key: str) -> Any:
        p = spec.params
        if spec.kind == "morph":
            # the manifest keys (_MORPH_KEYS) are create_morph's own
            return self.c.create_morph(ids, landmarks=spec.landmarks, idempotency_key=key, **p)
        if spec.kind == "morph2d":
            return self.c.create_morph2d(
                ids[0], ids[1], anchors=spec.anchors, idempotency_key=key, **p
            )
        if spec.kind == "conformal_map":
            return self.c.create_conformal_map(ids[0], idempotency_key=key, **p)
        return self.c.create_reconstruction(ids[0], idempotency_key=key, **p)

    def run(self, spec: JobSpec) -> Outcome:
        from conformorph_client import ApiError, NotFound, TransportError, WaitTimeout

        t0 = time.monotonic()
        jobdir = self.outdir / spec.name
        digests = [file_sha256(m) for m in spec.meshes]
        fp = fingerprint(spec, digests)
        rec = self.state.job(spec.name)
        if rec.get("fingerprint") != fp:
            rec = {}  # the manifest entry changed: a new job
        if rec.get("status") == "done" and _outputs_present(self.outdir, rec):
            return Outcome(spec.name, "skipped", rec.get("job_id"), None, "already finished")
        if rec.get("status") == "failed" and not self.args.retry_failed:
            return Outcome(spec.name, "failed", rec.get("job_id"), None, rec.get("error", "failed"))
        attempt = int(rec.get("attempt", 0)) + (1 if rec.get("status") == "failed" else 0)
        uploads = 0
        task = None
        try:
            job = None
            if rec.get("job_id") and rec.get("status") != "failed":
                try:
                    job = self.c.get_job(rec["job_id"])
                except NotFound:
                    job = None  # the server forgot it: submit again
            if job is None:
                ids, sent = self._upload_all(spec, digests)
                uploads += sent
                key = f"{fp}-{attempt}" if attempt else fp
                try:
                    job = self._submit(spec, ids, key)
                except NotFound as exc:
                    if not (exc.field or "").startswith(("mesh", "source", "target")):
                        raise
                    # uploads recorded here are gone from the server: upload again, once
                    self.state.forget_uploads()
                    ids, sent = self._upload_all(spec, digests)
                    uploads += sent
                    job = self._submit(spec, ids, key)
                self.state.set_job(
                    spec.name,
                    fingerprint=fp,
                    job_id=job.id,
                    status="submitted",
                    attempt=attempt,
                    error=None,
                )
            if self.progress is not None:
                task = self.progress.add_task(stage_text(job), total=1.0, label=spec.name)

            def update(j: Any) -> None:
                if task is not None:
                    self.progress.update(task, completed=j.progress, description=stage_text(j))

            job = self._wait(job.id, update)
            if job.state != "succeeded":
                reason = format_job_error(job)
                self.state.set_job(spec.name, status="failed", error=reason)
                return Outcome(spec.name, "failed", job.id, time.monotonic() - t0, reason, uploads)
            paths = download_results(self.c, job, jobdir, bool(spec.params.get("per_frame")))
            files = [str(p.relative_to(self.outdir.resolve())) for p in paths]
            self.state.set_job(spec.name, status="done", files=files)
            return Outcome(spec.name, "done", job.id, time.monotonic() - t0, "", uploads)
        except ApiError as exc:
            # the server refused the request itself: final until the manifest changes
            reason = f"server refused: {exc}"
            if 400 <= exc.status < 500 and exc.status != 429:
                self.state.set_job(spec.name, fingerprint=fp, status="failed", error=reason)
            return Outcome(spec.name, "failed", rec.get("job_id"), None, reason, uploads)
        except (TransportError, WaitTimeout) as exc:
            return Outcome(spec.name, "failed", rec.get("job_id"), None, str(exc), uploads)
        finally:
            if task is not None:
                self.progress.remove_task(task)
            if self.overall is not None:
                self.progress.advance(self.overall)


def print_summary(outcomes: list[Outcome], wall: float) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"conformorph batch: {len(outcomes)} jobs in {wall:.1f} s")
    for col in ("job", "status", "job id", "seconds", "uploads", "detail"):
        table.add_column(col, justify="right" if col in ("seconds", "uploads") else "left")
    for o in outcomes:
        table.add_row(
            o.name,
            o.status,
            o.job_id or "-",
            f"{o.seconds:.1f}" if o.seconds is not None else "-",
            str(o.uploads),
            o.detail,
        )
    console = Console(width=max(120, Console().width), soft_wrap=False)
    console.print(table)
    counts = {s: sum(o.status == s for o in outcomes) for s in ("done", "skipped", "failed")}
    print(
        f"done {counts['done']}, skipped {counts['skipped']}, failed {counts['failed']}; "
        f"uploads {sum(o.uploads for o in outcomes)}"
    )


def run_batch(args: argparse.Namespace) -> int:
    """Handler of ``conformorph batch``."""
    from conformorph_client import Client

    if args.parallel < 1:
        raise ValueError(f"--parallel must be at least 1, got {args.parallel}")
    specs = load_manifest(args.manifest)
    outdir = Path(args.output)
    outdir.mkdir(parents=True, exist_ok=True)
    state = BatchState(outdir, args.server.rstrip("/"))
    state.save()
    t0 = time.monotonic()
    with Client(args.server, args.api_key) as c:
        runner = Runner(c, state, outdir, args)
        if use_bars(args.quiet):
            with job_bars() as progress:
                runner.progress = progress
                runner.overall = progress.add_task(
                    "jobs", total=len(specs), label=f"batch ({len(specs)} jobs)"
                )
                outcomes = _run_all(runner, specs, args.parallel)
        else:
            outcomes = _run_all(runner, specs, args.parallel)
    print_summary(outcomes, time.monotonic() - t0)
    failed = [o for o in outcomes if o.status == "failed"]
    for o in failed:
        print(f"conformorph batch: {o.name}: {o.detail}", file=sys.stderr)
    return 1 if failed else 0


def _run_all(runner: Runner, specs: list[JobSpec], parallel: int) -> list[Outcome]:
    pool = ThreadPoolExecutor(max_workers=parallel, thread_name_prefix="batch")
    try:
        outcomes = list(pool.map(runner.run, specs))
    except KeyboardInterrupt:
        # every finished step is already in the state file; the server keeps
        # running what was submitted, and a re-run picks it up
        pool.shutdown(wait=False, cancel_futures=True)
        print(
            "conformorph batch: interrupted; run the same command again to resume", file=sys.stderr
        )
        sys.stderr.flush()
        sys.stdout.flush()
        os._exit(130)
    pool.shutdown()
    return outcomes
