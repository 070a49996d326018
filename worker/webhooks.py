"""Sending jobs' webhooks: the sweep that dispatches due callbacks and the delivery
of one (see :mod:`conformorph.worker.callbacks` for the destination rules and the signature).

Every worker's requeuer thread calls :func:`dispatch_due_callbacks` every
``requeue_check_seconds``: a job that ended (whoever ended it: a stage, the
requeuer, or the API cancelling it) has its callback sent to a worker as the task
``conformorph.deliver_callback``, which calls :func:`deliver_job_callback`.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

from celery import Celery

from conformorph.worker import names
from conformorph.worker.callbacks import Attempt, CallbackPolicy, backoff_seconds, deliver
from conformorph.worker.config import WorkerSettings
from conformorph.worker.job_record import job_record
from conformorph.worker.job_store import JobStore
from conformorph.worker.job_store.callbacks import DELIVERED, FAILED, PENDING
from conformorph.worker.secret_box import SecretUnreadable, box_for

log = logging.getLogger(__name__)


def dispatch_due_callbacks(store: JobStore, app: Celery, settings: WorkerSettings) -> list[str]:
    """Send the delivery task of every due callback this caller wins; returns the job ids."""
    sent = []
    for job_id in store.due_callbacks():
        if store.take_callback(job_id, settings.callback_redispatch_seconds):
            app.send_task(names.DELIVER_CALLBACK, args=(job_id,), queue=names.QUEUE_WEBHOOKS)
            sent.append(job_id)
    return sent


@dataclass(frozen=True)
class DeliveryOutcome:
    """``status``: the callback's status after this attempt (``pending``, ``delivered``,
    ``failed``) or ``skipped`` (nothing to do); ``retry_in``: seconds until the retry."""

    status: str
    retry_in: float | None = None


def deliver_job_callback(store: JobStore, settings: WorkerSettings, job_id: str) -> DeliveryOutcome:
    """One delivery attempt of job ``job_id``'s webhook, recorded on the job.

    Does nothing when the callback is not pending or the job has not ended (a
    redelivered or duplicated task). A transient failure with attempts left stays
    ``pending`` and answers the back-off before the retry; the sweep sends it
    again if that retry is lost (``callback_redispatch_seconds`` after it is due).
    """
    cb = store.get_callback(job_id)
    job = store.get_job(job_id)
    if cb is None or job is None or cb.status != PENDING or job.state not in names.TERMINAL_STATES:
        return DeliveryOutcome("skipped")
    policy = CallbackPolicy.parse(settings.callback_allow)
    try:
        secret = box_for(settings).open(cb.secret)  # stored encrypted (secret_box)
    except SecretUnreadable as exc:
        log.error("job %s: %s", job_id, exc)
        attempt = Attempt("refused", None, str(exc), 0.0)
    else:
        attempt = deliver(
            cb.url,
            job_record(job, cb),
            secret=secret,
            policy=policy,
            timeout=settings.callback_timeout,
        )
    number = len(cb.attempts) + 1
    now = time.time()
    retry_in = None
    if attempt.outcome == "delivered":
        status = DELIVERED
    elif attempt.outcome == "retry" and number < settings.callback_max_attempts:
        status = PENDING
        retry_in = backoff_seconds(number, settings.callback_backoff_seconds)
    else:
        status = FAILED
    due = now + (retry_in or 0.0) + settings.callback_redispatch_seconds
    store.record_callback_attempt(
        job_id, attempt.record(number, job.state, now), status=status, next_attempt_at=due
    )
    log.info(
        "webhook of job %s, attempt %d: %s (%s)",
        job_id,
        number,
        attempt.outcome,
        attempt.status_code or attempt.error,
    )
    return DeliveryOutcome(status, retry_in)
