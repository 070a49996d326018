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
import time

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


def requeue_waiting(
    store: JobStore, app: Celery, settings: WorkerSettings, down_at: float
) -> list[str]:
    """Send again every active job no worker holds, after a broker outage.

    A broker that restarts can lose the messages of queued jobs (and of jobs between
    two stages); their queued lease (``queued_requeue_seconds``, 15 minutes) would
    resend them only then. Sending a job whose message survived is harmless: a stage
    runs only under the job's lease (a second message finds it busy or done), so no
    stage runs twice.

    Parameters
    ----------
    store : JobStore
    app : Celery
    settings : WorkerSettings
    down_at : float
        When this worker last found the broker not answering (unix seconds): jobs
        touched since (claimed, or sent again by another worker's requeuer once the
        broker answered) are left alone.

    Returns
    -------
    list of str
        The ids sent again.
    """
    sent = []
    for job_id in store.waiting_jobs(down_at):
        job = store.take_waiting(job_id, down_at, grace_seconds=settings.queued_requeue_seconds)
        if job is None:
            continue
        send_job(app, job_id, job.remaining_stages)
        sent.append(job_id)
    if sent:
        log.warning("broker back: %d waiting job(s) sent again: %s", len(sent), sent)
    return sent


def broker_reachable(app: Celery) -> bool:
    """True when the broker accepts a connection (one try, 2 s at most)."""
    try:
        with app.connection_for_write() as conn:
            conn.ensure_connection(max_retries=1, timeout=2)
    except Exception:  # noqa: BLE001 - any failure means "not reachable now"
        return False
    return True


class Requeuer(threading.Thread):
    """Background thread calling :func:`requeue_expired` (when ``lease_requeue``) and
    :func:`conformorph.worker.webhooks.dispatch_due_callbacks` every few seconds, and
    :func:`requeue_waiting` when the broker answers again after it did not."""

    def __init__(self, store: JobStore, app: Celery, settings: WorkerSettings) -> None:
        super().__init__(daemon=True, name="conformorph-requeuer")
        self.store, self.app, self.settings = store, app, settings
        self.stopped = threading.Event()
        #: whether the broker answered at the last check (None: not checked yet)
        self.broker_up: bool | None = None
        #: when the last check that found the broker not answering began
        self.down_at = 0.0

    def broker_came_back(self) -> bool:
        """Check the broker; True once when it answers after a check it did not."""
        started = time.time()
        up = broker_reachable(self.app)
        if not up:
            self.down_at = started
        back = up and self.broker_up is False
        if self.broker_up is not None and up != self.broker_up:
            log.warning("broker %s", "answers again" if up else "does not answer")
        self.broker_up = up
        return back

    def run(self) -> None:
        while not self.stopped.wait(self.settings.requeue_check_seconds):
            try:
                if self.settings.lease_requeue:
                    # the embedded broker is files beside the job store: nothing restarts
                    if not self.settings.is_embedded and self.broker_came_back():
                        requeue_waiting(self.store, self.app, self.settings, self.down_at)
                    requeue_expired(self.store, self.app, self.settings)
                dispatch_due_callbacks(self.store, self.app, self.settings)
            except OperationalError as exc:
                log.warning("requeue check failed: %s", exc)
            except Exception:  # noqa: BLE001 - keep the thread alive, log the bug
                log.exception("requeue check crashed")
