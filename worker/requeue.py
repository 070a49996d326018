"""The job store's own redelivery: requeue jobs whose lease ran out.

Every worker runs a :class:`Requeuer` thread in its main process. It looks for
queued or running jobs whose lease expired (their worker was SIGKILLed, lost
power, or the message vanished), takes each with one conditional UPDATE so
that exactly one requeuer wins, and sends the job's remaining stages again.
A job that keeps losing its worker is failed after ``max_attempts`` extra
claims instead of looping forever.
"""

from __future__ import annotations

import logging
import threading

from celery import Celery
from sqlalchemy.exc import OperationalError

from conformorph.worker.config import WorkerSettings
from conformorph.worker.dispatch import send_job
from conformorph.worker.job_store import JobStore
from conformorph.worker.webhooks import dispatch_due_callbacks

log = logging.getLogger(__name__)


def requeue_expired(store: JobStore, app: Celery, settings: WorkerSettings) -> list[str]:
    """Requeue (or give up on) every job whose lease expired; returns the requeued ids."""
    requeued: list[str] = []
    for job_id in store.expired_jobs():
        job = store.take_expired(job_id, grace_seconds=settings.queued_requeue_seconds)
        if job is None:
            continue
        if job.attempts >= len(job.stages) + settings.max_attempts:
            store.fail_job(
                job_id,
                {
                    "type": "worker_lost",
                    "message": (
                        f"the job lost its worker too often ({job.attempts} claims for "
                        f"{len(job.stages)} stages); giving up"
                    ),
                    "field": None,
                    "stage": job.stage,
                },
            )
            log.warning("job %s failed: worker lost %d times", job_id, job.attempts)
            continue
        send_job(app, job_id, job.remaining_stages)
        log.warning("job %s requeued from stage %s (lease expired)", job_id, job.remaining_stages)
        requeued.append(job_id)
    return requeued


class Requeuer(threading.Thread):
    """Background thread calling :func:`requeue_expired` (when ``lease_requeue``) and
    :func:`conformorph.worker.webhooks.dispatch_due_callbacks` every few seconds."""

    def __init__(self, store: JobStore, app: Celery, settings: WorkerSettings) -> None:
        super().__init__(daemon=True, name="conformorph-requeuer")
        self.store, self.app, self.settings = store, app, settings
        self.stopped = threading.Event()

    def run(self) -> None:
        while not self.stopped.wait(self.settings.requeue_check_seconds):
            try:
                if self.settings.lease_requeue:
                    requeue_expired(self.store, self.app, self.settings)
                dispatch_due_callbacks(self.store, self.app, self.settings)
            except OperationalError as exc:
                log.warning("requeue check failed: %s", exc)
            except Exception:  # noqa: BLE001 - keep the thread alive, log the bug
                log.exception("requeue check crashed")
