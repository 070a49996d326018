"""Sending jobs to the workers: a chain of one task per remaining stage.

Used by the API (through its thin client app) and by the requeuer. Messages
carry the job id only; everything else is read from the job store.
"""

from __future__ import annotations

from collections.abc import Sequence

from celery import Celery, chain
from celery.result import AsyncResult

from conformorph.worker import names


def send_job(app: Celery, job_id: str, stages: Sequence[str]) -> AsyncResult | None:
    """Send ``stages`` of job ``job_id`` as one chain; None when nothing remains."""
    sigs = [
        app.signature(names.STAGE_TASKS[s], args=(job_id,), immutable=True, queue=names.QUEUE_JOBS)
        for s in stages
    ]
    if not sigs:
        return None
    result: AsyncResult = chain(*sigs).apply_async()
    return result
