"""Running one stage of one job: claim the lease, keep it alive, call the body, record.

The Celery tasks in ``worker/tasks.py`` are thin wrappers around
:func:`run_stage`; tests call it directly (no eager mode). A stage body gets a
:class:`StageContext` and returns nothing: it loads inputs by key, calls one
geometry function, writes its artifacts atomically through the context and
reports progress.

Errors: numerical and input failures (``ValueError`` including every
``MeshError``, ``ArithmeticError`` including ``SingularSystemError`` and
``FoldedMapError``, Celery's soft time limit) end the job as ``failed`` with
the reason and are never retried. Transient failures (``OSError``, database
``OperationalError``) propagate as :class:`TransientStageError` so the Celery
task can retry them with back-off.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import signal
import socket
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sqlalchemy.exc import OperationalError

from conformorph.worker.config import WorkerSettings
from conformorph.worker.job_errors import api_error_type, api_message
from conformorph.worker.job_store import Claim, JobStore, JobView
from conformorph.worker.open_storage import open_storage
from conformorph.worker.storage import Storage, StoredObject

log = logging.getLogger(__name__)

CONTENT_TYPES = {
    ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json",
    ".json": "application/json",
    ".npz": "application/octet-stream",
    ".obj": "model/obj",
    ".ply": "application/octet-stream",
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".svg": "image/svg+xml",
    ".gif": "image/gif",
    ".csv": "text/csv",
}


def content_type_for(name: str) -> str:
    """The media type served for an artifact name."""
    return CONTENT_TYPES.get(Path(name).suffix.lower(), "application/octet-stream")


class TransientStageError(Exception):
    """A failure worth retrying (I/O or database hiccup)."""


class JobCancelled(Exception):
    """The job was cancelled or lost its lease while the stage ran."""


@contextmanager
def input_field(name: str) -> Iterator[None]:
    """Tag errors raised in the block with the input they concern (``meshes[1]``)."""
    try:
        yield
    except Exception as exc:
        if not hasattr(exc, "conformorph_field"):
            exc.conformorph_field = name  # type: ignore[attr-defined]
        raise


#: top-level packages whose own ``ValueError``/``ArithmeticError`` messages are written for users
_OWN_PACKAGES = ("geometry", "pipelines", "worker", "cli")
_ROOT = Path(__file__).resolve().parents[1]


def _raised_by_us(exc: BaseException) -> bool:
    """True when the innermost frame of ``exc``'s traceback is in one of our packages."""
    tb = exc.__traceback__
    if tb is None:
        return True  # built and passed around, not raised: ours
    while tb.tb_next is not None:
        tb = tb.tb_next
    try:
        rel = Path(tb.tb_frame.f_code.co_filename).resolve().relative_to(_ROOT)
    except ValueError:
        return False
    return rel.parts[0] in _OWN_PACKAGES


def error_body(exc: BaseException, stage: str) -> dict[str, Any]:
    """The job's ``error`` record: type, message, field (the input concerned), stage.

    The message is one a client can read: a domain error's own text (an
    exception with a ``code``, or a ``ValueError``/``ArithmeticError`` raised
    by our packages) in the API's words (:mod:`conformorph.worker.job_errors`:
    our named code, never a class name; paths and key ids replaced by the
    input, CLI flags by job fields); anything else (a library's raw text such
    as "list index out of range", a storage path) is logged on the worker and
    reported as ``internal_error`` or ``storage_error`` without its text.
    """
    code = getattr(exc, "code", None)
    field = getattr(exc, "conformorph_field", None)
    if type(exc).__name__ == "SoftTimeLimitExceeded":
        etype, msg = "time_limit", f"stage {stage!r} exceeded its time limit"
    elif isinstance(code, str) or (
        isinstance(exc, ValueError | ArithmeticError) and _raised_by_us(exc)
    ):
        etype = api_error_type(exc)
        msg = api_message(str(exc), field) or etype
    elif isinstance(exc, OSError):
        log.error("stage %s failed on storage", stage, exc_info=exc)
        etype, msg = "storage_error", f"stage {stage!r} could not read or write its files"
    else:
        log.error("stage %s failed", stage, exc_info=exc)
        etype = "internal_error"
        msg = f"stage {stage!r} failed because of an internal error (logged on the worker)"
    return {
        "type": etype,
        "message": msg[:2000],
        "field": field,
        "stage": stage,
    }


def params_hash(params: dict[str, Any]) -> str:
    """Short stable hash of a job's parameters (part of artifact keys)."""
    blob = json.dumps(params, sort_keys=True, separators=(",", ":")).encode()
    return hashlib.sha256(blob).hexdigest()[:12]


def worker_identity() -> str:
    """Unique id of this process (host, pid, random suffix)."""
    return f"{socket.gethostname()}:{os.getpid()}:{os.urandom(3).hex()}"


@dataclass
class Runtime:
    """Per-process handles: settings, job store, storage."""

    settings: WorkerSettings
    store: JobStore
    storage: Storage
    worker_id: str = field(default_factory=worker_identity)


_runtime: dict[int, Runtime] = {}


def get_runtime(settings: WorkerSettings) -> Runtime:
    """The runtime of this process (created after fork, once per pid)."""
    pid = os.getpid()
    rt = _runtime.get(pid)
    if rt is None:
        rt = Runtime(
            settings,
            JobStore(settings.resolved_database_url),
            open_storage(settings),
        )
        _runtime.clear()
        _runtime[pid] = rt
    return rt


@dataclass
class StageContext:
    """What a stage body sees: the job, storage, artifact writers, progress."""

    job: JobView
    stage: str
    storage: Storage
    store: JobStore
    worker_id: str
    artifacts: dict[str, dict[str, Any]] = field(default_factory=dict)
    _last_progress: float = 0.0

    @property
    def params(self) -> dict[str, Any]:
        return self.job.params

    def key(self, name: str) -> str:
        """Deterministic key: ``jobs/<job>/<stage>-<params hash>/<name>``."""
        return f"jobs/{self.job.id}/{self.stage}-{params_hash(self.job.params)}/{name}"

    def _record(self, name: str, obj: StoredObject, internal: bool) -> dict[str, Any]:
        rec = {
            "key": obj.key,
            "size": obj.size,
            "etag": obj.sha256,
            "content_type": content_type_for(name),
            "stage": self.stage,
            "internal": internal,
        }
        self.artifacts[name] = rec
        return rec

    def put_bytes(self, name: str, data: bytes, *, internal: bool = False) -> dict[str, Any]:
        """Write artifact ``name`` atomically and record it on the job.

        ``internal`` artifacts (intermediate stage results) are kept for the
        next stages but neither listed nor served.
        """
        return self._record(name, self.storage.put_bytes(self.key(name), data), internal)

    def put_json(self, name: str, obj: Any) -> dict[str, Any]:
        return self.put_bytes(name, json.dumps(obj, indent=2, sort_keys=True).encode())

    def put_file(self, name: str, path: Path, *, internal: bool = False) -> dict[str, Any]:
        """Move a file made by the body into storage as artifact ``name``."""
        return self._record(name, self.storage.put_file(self.key(name), path, move=True), internal)

    def artifact_path(self, name: str) -> Path:
        """Local path of an artifact written by an earlier stage of this job."""
        rec = self.job.artifacts.get(name) or self.artifacts.get(name)
        if rec is None:
            raise TransientStageError(f"artifact {name!r} of an earlier stage is missing")
        return self.storage.local_path(str(rec["key"]))

    @contextmanager
    def scratch_dir(self) -> Iterator[Path]:
        """A temporary folder on the storage filesystem (for tools that write files)."""
        with tempfile.TemporaryDirectory(dir=self.storage.staging_dir()) as d:
            yield Path(d)

    def progress(self, fraction: float) -> None:
        """Report progress within this stage (0-1), at most ~5 times a second."""
        now = time.monotonic()
        if now - self._last_progress < 0.2 and fraction < 1.0:
            return
        self._last_progress = now
        n = max(1, len(self.job.stages))
        done = len([s for s in self.job.stages_done if s != self.stage])
        self.store.set_progress(self.job.id, self.worker_id, (done + float(fraction)) / n)


StageBody = Callable[[StageContext], None]


@dataclass(frozen=True)
class StageOutcome:
    """``status``: ran, failed, done (already finished), busy, gone, cancelled."""

    status: str
    job: JobView | None
    wait: float = 0.0


def _interrupt_handler_installed() -> bool:
    """True in a Celery prefork child, where SIGUSR1 raises SoftTimeLimitExceeded."""
    sig = getattr(signal, "SIGUSR1", None)
    if sig is None or threading.current_thread() is not threading.main_thread():
        return False
    handler = signal.getsignal(sig)
    return callable(handler) and getattr(handler, "__module__", "").startswith("billiard")


class _LeaseKeeper(threading.Thread):
    """Renews the lease every third of its length and watches for cancellation.

    When the job is cancelled (or the lease is lost) while the stage runs and
    ``interrupt`` is set, it sends SIGUSR1 to its own process: in a Celery
    prefork child that raises ``SoftTimeLimitExceeded`` in the stage body at
    the next Python bytecode, so the stage stops within about a second and
    the same pool process goes on with the next task (terminating the child
    instead races with billiard handing it the next task).
    """

    def __init__(
        self, store: JobStore, job_id: str, worker_id: str, lease: float, interrupt: bool
    ) -> None:
        super().__init__(daemon=True, name=f"lease-{job_id[:8]}")
        self.store, self.job_id, self.worker_id, self.lease = store, job_id, worker_id, lease
        self.interrupt = interrupt
        self.stop = threading.Event()
        self.lost = threading.Event()

    def run(self) -> None:
        renew_every = self.lease / 3.0
        last_renew = time.monotonic()
        while not self.stop.wait(min(1.0, renew_every)):
            try:
                if time.monotonic() - last_renew >= renew_every:
                    ok = self.store.renew_lease(self.job_id, self.worker_id, self.lease)
                    last_renew = time.monotonic()
                else:
                    job = self.store.get_job(self.job_id)
                    ok = (
                        job is not None
                        and job.state == "running"
                        and job.lease_owner == self.worker_id
                    )
            except OperationalError:
                continue
            if not ok:
                self.lost.set()
                if self.interrupt and not self.stop.is_set():
                    os.kill(os.getpid(), signal.SIGUSR1)
                return


def run_stage(
    rt: Runtime,
    job_id: str,
    stage: str,
    body: StageBody,
    *,
    task_id: str | None = None,
) -> StageOutcome:
    """Run ``stage`` of ``job_id`` under a lease (see the module docstring)."""
    settings = rt.settings
    try:
        claim: Claim = rt.store.claim_stage(
            job_id, stage, rt.worker_id, settings.lease_seconds, task_id
        )
    except OperationalError as exc:
        raise TransientStageError(str(exc)) from exc
    if claim.status != "claimed" or claim.job is None:
        return StageOutcome(claim.status, claim.job, claim.wait)
    job = claim.job
    ctx = StageContext(
        job=job, stage=stage, storage=rt.storage, store=rt.store, worker_id=rt.worker_id
    )
    keeper = _LeaseKeeper(
        rt.store, job_id, rt.worker_id, settings.lease_seconds, _interrupt_handler_installed()
    )
    keeper.start()
    t0 = time.perf_counter()
    try:
        body(ctx)
    except TransientStageError:
        raise
    except (OSError, OperationalError) as exc:
        if isinstance(exc, FileNotFoundError | PermissionError | IsADirectoryError):
            rt.store.fail_job(job_id, error_body(exc, stage))
            return StageOutcome("failed", rt.store.get_job(job_id))
        raise TransientStageError(f"{type(exc).__name__}: {exc}") from exc
    except Exception as exc:  # noqa: BLE001 - numerical/input failures are final
        keeper.stop.set()
        if keeper.lost.is_set():
            return StageOutcome("cancelled", rt.store.get_job(job_id))
        rt.store.fail_job(job_id, error_body(exc, stage))
        return StageOutcome("failed", rt.store.get_job(job_id))
    finally:
        keeper.stop.set()
    seconds = time.perf_counter() - t0
    after = rt.store.complete_stage(
        job_id,
        stage,
        rt.worker_id,
        seconds=seconds,
        artifacts=ctx.artifacts,
        handoff_lease_seconds=settings.queued_requeue_seconds,
    )
    if after is None or after.state == "cancelled":
        return StageOutcome("cancelled", after)
    return StageOutcome("ran", after)


def fail_after_retries(rt: Runtime, job_id: str, stage: str, exc: BaseException) -> None:
    """End the job as failed after its transient error kept coming back."""
    body = error_body(exc, stage)
    body["type"] = "transient_error_exhausted"
    rt.store.fail_job(job_id, body)
