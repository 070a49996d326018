"""The retention cleanup: finished jobs and their artifacts after
``CONFORMORPH_JOB_RETENTION_SECONDS``, uploads no job used for
``CONFORMORPH_UPLOAD_RETENTION_SECONDS``.

Run by the task ``conformorph.cleanup`` (on Redis or RabbitMQ: Celery beat,
``conformorph worker --beat``; with ``conformorph serve``: its own timer sends the
same task). Files go through the :class:`conformorph.worker.storage.Storage` protocol only
(``delete``, ``delete_prefix``), so any storage implementation works.

Safe to run twice, or on several hosts at once: a finished job never becomes
live again, so its artifacts are deleted before its row (a crash between the
two leaves the row for the next run), and the row is deleted with a conditional
DELETE that exactly one run wins (that run counts it). Uploads are chosen and
deleted under the per-owner job lock (:mod:`conformorph.worker.job_store.retention`), and an
upload's file is kept when the same bytes were uploaded again meanwhile.
"""

from __future__ import annotations

import logging
import time

from conformorph.worker.job_store import CleanupReport, JobStore
from conformorph.worker.job_store.retention import artifact_bytes
from conformorph.worker.storage import Storage

log = logging.getLogger(__name__)


def remove_expired_jobs(store: JobStore, storage: Storage, cutoff: float) -> tuple[int, int]:
    """Delete jobs finished before ``cutoff`` with their artifacts; (jobs, bytes) freed."""
    jobs = freed = 0
    while True:
        batch = store.expired_jobs_before(cutoff)
        if not batch:
            return jobs, freed
        for job in batch:
            storage.delete_prefix(f"jobs/{job.id}")
            if store.remove_expired_job(job.id, cutoff):
                jobs += 1
                freed += artifact_bytes(job)


def remove_unused_uploads(store: JobStore, storage: Storage, cutoff: float) -> tuple[int, int]:
    """Delete uploads no job used since ``cutoff`` (none live) and the key artifacts of
    the meshes among them; (uploads, bytes) freed."""
    uploads = freed = 0
    for owner in store.owners_with_old_uploads(cutoff):
        for up in store.remove_unused_uploads(owner, cutoff):
            uploads += 1
            freed += up.size
            # the same bytes uploaded again since the row went: the file is theirs now
            if up.storage_key is not None and not store.storage_key_in_use(up.storage_key):
                storage.delete(up.storage_key)
            # the mesh's key artifacts (its per-mesh work) go with it
            for key, size in store.remove_key_artifacts(owner, up.id):
                storage.delete(key)
                freed += size
    return uploads, freed


def run_cleanup(
    store: JobStore,
    storage: Storage,
    *,
    job_retention_seconds: float,
    upload_retention_seconds: float,
    now: float | None = None,
) -> CleanupReport:
    """One cleanup pass; returns what it freed (also logged and added to the totals).

    Parameters
    ----------
    store, storage : JobStore, Storage
        Where the rows and the files are.
    job_retention_seconds : float
        A finished job is deleted this long after it ended (0 or less: never).
    upload_retention_seconds : float
        An upload is deleted when no queued or running job uses it and no job
        created in this long used it, and it is at least this old (0 or less: never).
    now : float, optional
        The current time (seconds since the epoch); default ``time.time()``.
    """
    t0 = time.perf_counter()
    now = time.time() if now is None else float(now)
    jobs = uploads = freed = 0
    if job_retention_seconds > 0:
        jobs, freed = remove_expired_jobs(store, storage, now - job_retention_seconds)
    if upload_retention_seconds > 0:
        uploads, up_bytes = remove_unused_uploads(store, storage, now - upload_retention_seconds)
        freed += up_bytes
    report = CleanupReport(jobs, uploads, freed, time.perf_counter() - t0)
    store.add_cleanup_totals(report)
    log.info(
        "cleanup freed %d job(s), %d upload(s), %d bytes in %.3f s",
        jobs,
        uploads,
        freed,
        report.seconds,
    )
    return report
