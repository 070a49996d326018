"""Retention in the job store: finished jobs past their time, uploads no job has used
for a while, what each owner stores (for the quota), and the cleanup's running totals.

Files are deleted by :func:`conformorph.worker.retention.run_cleanup` through the Storage
protocol; this module decides, under the same per-owner lock that job creation
takes (:func:`conformorph.worker.job_store.engine.lock_owner_jobs`), which rows go. So an
upload is either deleted before a job naming it is created (and the creation
fails with :class:`conformorph.worker.job_store.jobs.InputGone`) or kept because that job
exists: a cleanup never deletes a live job's input.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Any

from sqlalchemy import delete, select, update

from conformorph.worker import names
from conformorph.worker.job_store.base import StoreBase
from conformorph.worker.job_store.engine import lock_owner_jobs
from conformorph.worker.job_store.references import FILE_TABLES, used_ids
from conformorph.worker.job_store.tables import (
    CallbackRecord,
    CleanupTotal,
    ExpiredUpload,
    JobRecord,
    KeyArtifactRecord,
    LandmarkSetRecord,
)
from conformorph.worker.job_store.views import JobView

#: how long a deleted upload's id is remembered (for ``input_expired``): 90 days
EXPIRED_UPLOAD_MEMORY_SECONDS = 90 * 86400.0


@dataclass(frozen=True)
class CleanupReport:
    """What one cleanup freed: jobs and uploads deleted, bytes of files deleted
    (artifacts and uploaded files), and its duration."""

    jobs: int = 0
    uploads: int = 0
    bytes: int = 0
    seconds: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        return {
            "jobs": self.jobs,
            "uploads": self.uploads,
            "bytes": self.bytes,
            "seconds": round(self.seconds, 4),
        }


@dataclass(frozen=True)
class DeletedUpload:
    """An upload row the cleanup deleted: its storage key (None: a landmark set, kept
    in the database only) and its size in bytes."""

    owner: str
    id: str
    storage_key: str | None
    size: int


def artifact_bytes(job: JobView) -> int:
    """Bytes of the job's stored artifacts (internal ones included)."""
    return sum(int(rec.get("size") or 0) for rec in job.artifacts.values())


class RetentionStore(StoreBase):
    """Expiry of jobs and uploads, storage use per owner, cleanup totals."""

    def expired_jobs_before(self, cutoff: float, limit: int = 500) -> list[JobView]:
        """Finished (succeeded, failed, cancelled) jobs that ended before ``cutoff``."""
        with self.session() as s:
            rows = s.scalars(
                select(JobRecord)
                .where(
                    JobRecord.state.in_(names.TERMINAL_STATES),
                    JobRecord.finished_at.is_not(None),
                    JobRecord.finished_at < cutoff,
                )
                .order_by(JobRecord.finished_at)
                .limit(limit)
            )
            return [JobView.of(r) for r in rows]

    def remove_expired_job(self, job_id: str, cutoff: float) -> bool:
        """Delete the job row (and its webhook row) if it still ended before ``cutoff``;
        True for the one caller that deleted it."""
        with self.session() as s:
            res = s.execute(
                delete(JobRecord)
                .where(
                    JobRecord.id == job_id,
                    JobRecord.state.in_(names.TERMINAL_STATES),
                    JobRecord.finished_at < cutoff,
                )
                .execution_options(synchronize_session=False)
            )
            s.execute(delete(CallbackRecord).where(CallbackRecord.job_id == job_id))
            return bool(res.rowcount == 1)  # type: ignore[attr-defined]

    def owners_with_old_uploads(self, cutoff: float) -> list[str]:
        """Owners having an upload (file or landmark set) created before ``cutoff``."""
        owners: set[str] = set()
        with self.session() as s:
            for table in (*FILE_TABLES, LandmarkSetRecord):
                owners.update(
                    s.scalars(select(table.owner).where(table.created_at < cutoff).distinct())
                )
        return sorted(owners)

    def remove_unused_uploads(self, owner: str, cutoff: float) -> list[DeletedUpload]:
        """Delete ``owner``'s uploads created before ``cutoff`` that no queued or
        running job uses and no job created since ``cutoff`` used; returns them.

        Runs under the owner's job lock, so no job naming one of them is created
        meanwhile (see the module docstring).
        """
        deleted: list[DeletedUpload] = []
        with self.session() as s:
            lock_owner_jobs(s, owner)
            keep: set[str] = set()
            jobs = s.execute(
                select(JobRecord.state, JobRecord.created_at, JobRecord.params).where(
                    JobRecord.owner == owner
                )
            )
            for state, created_at, params in jobs:
                if state in names.ACTIVE_STATES or created_at >= cutoff:
                    keep.update(used_ids(params or {}))
            for table in FILE_TABLES:
                rows: Any = s.scalars(
                    select(table).where(table.owner == owner, table.created_at < cutoff)
                )
                for r in rows:
                    if r.id not in keep:
                        deleted.append(DeletedUpload(owner, r.id, r.storage_key, int(r.size_bytes)))
                        s.delete(r)
            for lm in s.scalars(
                select(LandmarkSetRecord).where(
                    LandmarkSetRecord.owner == owner, LandmarkSetRecord.created_at < cutoff
                )
            ):
                if lm.id not in keep:
                    deleted.append(DeletedUpload(owner, lm.id, None, len(json.dumps(lm.data))))
                    s.delete(lm)
            now = time.time()
            for d in deleted:  # a job naming one is told input_expired
                s.merge(ExpiredUpload(owner=owner, id=d.id, expired_at=now))
            s.execute(
                delete(ExpiredUpload).where(
                    ExpiredUpload.owner == owner,
                    ExpiredUpload.expired_at < now - EXPIRED_UPLOAD_MEMORY_SECONDS,
                )
            )
        return deleted

    def storage_key_in_use(self, key: str) -> bool:
        """True when an upload row names ``key`` (the same bytes uploaded again)."""
        with self.session() as s:
            return any(
                s.scalar(select(table.id).where(table.storage_key == key).limit(1)) is not None
                for table in FILE_TABLES
            )

    def storage_used(self, owner: str) -> int:
        """Bytes ``owner`` stores: uploaded files, every artifact of its jobs and the key
        artifacts of its meshes."""
        total = 0
        with self.session() as s:
            total += sum(
                int(n)
                for n in s.scalars(
                    select(KeyArtifactRecord.size_bytes).where(KeyArtifactRecord.owner == owner)
                )
            )
            for table in FILE_TABLES:
                total += sum(
                    int(n) for n in s.scalars(select(table.size_bytes).where(table.owner == owner))
                )
            for artifacts in s.scalars(select(JobRecord.artifacts).where(JobRecord.owner == owner)):
                total += sum(int(rec.get("size") or 0) for rec in (artifacts or {}).values())
        return total

    def add_cleanup_totals(self, report: CleanupReport) -> None:
        """Add ``report``'s counts to the running totals (``cleanup_totals``)."""
        for what, n in (
            ("jobs", report.jobs),
            ("uploads", report.uploads),
            ("bytes", report.bytes),
        ):
            self._insert_once(CleanupTotal(what=what, total=0))
            if n:
                with self.session() as s:
                    s.execute(
                        update(CleanupTotal)
                        .where(CleanupTotal.what == what)
                        .values(total=CleanupTotal.total + int(n))
                    )

    def cleanup_totals_recorded(self) -> bool:
        """True once a cleanup has run against this store (its totals exist)."""
        with self.session() as s:
            return s.scalar(select(CleanupTotal.what).limit(1)) is not None

    def cleanup_totals(self) -> dict[str, int]:
        """What every cleanup so far freed: ``{"jobs", "uploads", "bytes"}``."""
        out = {"jobs": 0, "uploads": 0, "bytes": 0}
        with self.session() as s:
            for what, total in s.execute(select(CleanupTotal.what, CleanupTotal.total)):
                out[str(what)] = int(total)
        return out
