"""Turning job rows into their public JSON (the record itself is built by
:func:`conformorph.worker.job_record.job_record`, which the webhook POSTs too)."""

from __future__ import annotations

from conformorph.service.schemas import JobPublic
from conformorph.worker.job_record import job_record
from conformorph.worker.job_store import CallbackView, JobStore, JobView


def job_public(job: JobView, callback: CallbackView | None = None) -> JobPublic:
    """The response model of ``job`` (with its webhook's status when it has one)."""
    return JobPublic.model_validate(job_record(job, callback))


def job_callback(store: JobStore, job: JobView) -> CallbackView | None:
    """The job's webhook row, looked up only for jobs created with a ``callback_url``."""
    return store.get_callback(job.id) if job.params.get("callback_url") else None
