"""Celery tasks: one per stage, the synchronous upload validation, webhook delivery
and the retention cleanup.

Each task is a thin wrapper: it takes a job id, runs the stage body under the
job's lease (:func:`conformorph.worker.job_runner.run_stage`), and either lets the chain
go on, stops it (job failed, cancelled, gone, or held by a live worker), or
retries a transient failure with back-off. Numerical failures are final.
"""

from __future__ import annotations

import logging
from typing import Any

from celery import Task, signals
from celery.exceptions import Ignore

from conformorph.worker import names, stages
from conformorph.worker.celery_app import create_celery_app, get_app
from conformorph.worker.config import get_worker_settings
from conformorph.worker.job_runner import (
    Runtime,
    TransientStageError,
    fail_after_retries,
    get_runtime,
    run_stage,
)
from conformorph.worker.key_artifacts import precompute_key_artifact
from conformorph.worker.preload import preload_for_queues
from conformorph.worker.requeue import Requeuer
from conformorph.worker.retention import run_cleanup
from conformorph.worker.secret_box import box_for, seal_plaintext_secrets
from conformorph.worker.storage import StorageUnavailable
from conformorph.worker.webhooks import deliver_job_callback

log = logging.getLogger(__name__)
app = get_app()


@signals.worker_init.connect
def _preload(sender: Any = None, **_: Any) -> None:
    # the worker's queues are selected (--queues) before worker_init is sent
    amqp = getattr(getattr(sender, "app", None), "amqp", None)
    queues = set(getattr(getattr(amqp, "queues", None), "consume_from", None) or ())
    failed = preload_for_queues(queues)
    if failed:
        log.warning("could not preload %s", ", ".join(failed))


_requeuer: Requeuer | None = None


def _rt() -> Runtime:
    return get_runtime(get_worker_settings())


@app.task(name=names.VALIDATE_MESH, acks_late=False, ignore_result=False)
def validate_mesh_task(
    key: str, file_type: str, max_vertices: int, max_faces: int
) -> dict[str, Any]:
    """Read and validate an uploaded mesh (the API waits for the answer)."""
    rt = _rt()
    return stages.validate_upload(
        rt.storage, key, file_type, max_vertices=max_vertices, max_faces=max_faces
    )


@app.task(name=names.VALIDATE_SHAPE, acks_late=False, ignore_result=False)
def validate_shape_task(key: str, max_points: int | None = None) -> dict[str, Any]:
    """Read and validate an uploaded 2D shape (the API waits for the answer)."""
    return stages.validate_shape_upload(_rt().storage, key, max_points=max_points)


@app.task(name=names.PRECOMPUTE_KEY, acks_late=True, ignore_result=True)
def precompute_key_task(owner: str, mesh_id: str) -> dict[str, Any]:
    """An uploaded mesh's key artifact (worker/key_artifacts.py), computed once for the
    morphs to come; safe to run twice (the second finds it)."""
    rt = _rt()
    options = stages.face_morph.default_key_options()
    return precompute_key_artifact(rt.storage, rt.store, owner, mesh_id, options)


@app.task(name=names.DELIVER_CALLBACK, bind=True, acks_late=True, ignore_result=True)
def deliver_callback_task(self: Task, job_id: str) -> dict[str, Any]:
    """POST the ended job's record to its ``callback_url``, once; a transient failure
    is retried with exponential back-off (``callback_backoff_seconds`` doubling) up to
    ``callback_max_attempts``, every attempt recorded on the job."""
    rt = _rt()
    out = deliver_job_callback(rt.store, rt.settings, job_id)
    if out.retry_in is not None:
        raise self.retry(countdown=out.retry_in, max_retries=None)
    return {"job_id": job_id, "status": out.status}


@app.task(name=names.CLEANUP, acks_late=True, ignore_result=True)
def cleanup_task() -> dict[str, Any]:
    """One retention pass (worker/retention.py); returns and logs what it freed."""
    rt = _rt()
    report = run_cleanup(
        rt.store,
        rt.storage,
        job_retention_seconds=rt.settings.job_retention_seconds,
        upload_retention_seconds=rt.settings.upload_retention_seconds,
    )
    return report.as_dict()


#: retries of a stage whose object store cannot be reached (StorageUnavailable), with
#: back-off doubling from 1 s up to STORAGE_RETRY_CAP_SECONDS: about 7 minutes in all
#: (1 + 2 + … + 32 + 6 × 60 s), so that a store restarted meanwhile finishes the job
STORAGE_OUTAGE_RETRIES = 12
STORAGE_RETRY_CAP_SECONDS = 60.0


def retry_plan(
    retries: int, exc: TransientStageError, task_max: int | None
) -> tuple[float, int | None] | None:
    """How a stage that failed transiently is retried, or None to give up.

    Parameters
    ----------
    retries : int
        Retries so far (Celery's ``request.retries``).
    exc : TransientStageError
        The failure; one caused by :class:`StorageUnavailable` (the object store is
        down) is retried up to :data:`STORAGE_OUTAGE_RETRIES` times with back-off
        doubling from 1 s to :data:`STORAGE_RETRY_CAP_SECONDS`, any other up to
        ``task_max`` times (1, 2, 4 … s).
    task_max : int or None
        The task's own ``max_retries``.

    Returns
    -------
    (countdown, max_retries) or None
        Seconds until the retry, and the ``max_retries`` to pass to Celery's ``retry``
        (whose None means the task's default, which would refuse an outage's 4th retry).
    """
    outage = isinstance(exc.__cause__, StorageUnavailable)
    if retries >= (STORAGE_OUTAGE_RETRIES if outage else (task_max or 0)):
        return None
    if outage:
        return min(2.0**retries, STORAGE_RETRY_CAP_SECONDS), STORAGE_OUTAGE_RETRIES + 1
    return 2.0**retries, None


def _run(task: Task, job_id: str, stage: str) -> dict[str, Any]:
    rt = _rt()
    try:
        out = run_stage(rt, job_id, stage, stages.ALL_STAGE_BODIES[stage], task_id=task.request.id)
    except TransientStageError as exc:
        plan = retry_plan(task.request.retries, exc, task.max_retries)
        if plan is None:
            fail_after_retries(rt, job_id, stage, exc)
            raise Ignore() from exc
        countdown, limit = plan
        try:  # the retry may land on another worker process: let it claim the stage
            rt.store.hand_back_lease(job_id, rt.worker_id, countdown + rt.settings.lease_seconds)
        except Exception:  # noqa: BLE001 - the database may be what failed: the lease expires
            log.warning("job %s: could not hand back the lease before a retry", job_id)
        raise task.retry(exc=exc, countdown=countdown, max_retries=limit) from exc
    if out.status == "busy":
        if rt.settings.lease_requeue:
            raise Ignore()  # the lease holder finishes it, or the requeuer resends it
        raise task.retry(countdown=out.wait + 0.5, max_retries=None)
    if out.status in ("failed", "gone", "cancelled"):
        raise Ignore()  # ends the chain
    return {"job_id": job_id, "stage": stage, "status": out.status}


def _make_stage_task(stage: str) -> Task:
    @app.task(
        name=names.STAGE_TASKS[stage],
        bind=True,
        acks_late=True,
        max_retries=3,
        ignore_result=True,
    )
    def stage_task(self: Task, job_id: str) -> dict[str, Any]:
        return _run(self, job_id, stage)

    return stage_task  # type: ignore[no-any-return]


STAGE_TASK_OBJECTS = {stage: _make_stage_task(stage) for stage in stages.ALL_STAGE_BODIES}


@signals.worker_ready.connect
def _start_requeuer(**_: Any) -> None:
    """Start the lease requeuer in the worker's main process."""
    global _requeuer
    settings = get_worker_settings()
    if _requeuer is not None:
        return
    rt = _rt()
    try:  # rows written before webhook secrets were encrypted (secret_box's migration)
        seal_plaintext_secrets(rt.store, box_for(settings))
    except Exception:  # noqa: BLE001 - never stops the worker; the next start tries again
        log.exception("could not encrypt plaintext webhook secrets")
    # it also sends the webhooks of ended jobs, so it runs even without lease requeue
    _requeuer = Requeuer(rt.store, create_celery_app(settings), settings)
    _requeuer.start()
    log.info("requeuer started (check every %.1fs)", settings.requeue_check_seconds)


@signals.worker_shutdown.connect
def _stop_requeuer(**_: Any) -> None:
    if _requeuer is not None:
        _requeuer.stopped.set()
