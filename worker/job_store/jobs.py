"""Job rows: creation (with the idempotency key and the per-owner active-job limit
checked atomically), reads, pages, counts, and the ends an API caller or the
broker gives a job (failed, cancelled, deleted)."""

from __future__ import annotations

import time
import uuid
from collections.abc import Sequence
from typing import Any

from sqlalchemy import ColumnElement, bindparam, delete, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from conformorph.worker import names
from conformorph.worker.job_store.base import StoreBase, count_rows, newest_first, present
from conformorph.worker.job_store.engine import lock_owner_jobs
from conformorph.worker.job_store.references import file_refs, missing_inputs
from conformorph.worker.job_store.tables import CallbackRecord, JobRecord
from conformorph.worker.job_store.views import JobView, view_of

_JOB_BY_ID = select(JobRecord.__table__).where(JobRecord.__table__.c.id == bindparam("job_id"))


class TooManyActiveJobs(Exception):
    """:meth:`JobRecordStore.create_job` with ``max_active``: the owner already has
    ``active`` queued or running jobs, and ``limit`` is the most allowed."""

    def __init__(self, owner: str, active: int, limit: int) -> None:
        super().__init__(f"this key has {active} queued or running jobs; the limit is {limit}")
        self.owner, self.active, self.limit = owner, active, limit


class InputGone(LookupError):
    """:meth:`JobRecordStore.create_job`: an uploaded file the job names was deleted
    (by the retention cleanup) after the route looked it up; ``ids`` are its ids."""

    def __init__(self, ids: list[str]) -> None:
        super().__init__(f"upload(s) {', '.join(ids)} expired and were deleted; upload again")
        self.ids = ids


def ended(state: str, now: float) -> dict[str, Any]:
    """Column values of a job entering the terminal ``state`` at ``now`` (lease released)."""
    return {
        "state": state,
        "finished_at": now,
        "updated_at": now,
        "lease_owner": None,
        "lease_until": None,
    }


def _queued_job(
    owner: str,
    kind: str,
    params: dict[str, Any],
    idempotency_key: str | None,
    queued_lease_seconds: float,
) -> JobRecord:
    """A new job row, queued, with all of ``kind``'s stages to run."""
    now = time.time()
    return JobRecord(
        id=uuid.uuid4().hex,
        owner=owner,
        kind=kind,
        state=names.QUEUED,
        stage=None,
        stages=names.stages_for(kind, params),
        stages_done=[],
        stage_seconds={},
        progress=0.0,
        params=params,
        error=None,
        artifacts={},
        idempotency_key=idempotency_key,
        created_at=now,
        updated_at=now,
        lease_owner=None,
        lease_until=now + queued_lease_seconds,
        attempts=0,
        requeues=0,
    )


def _callback_row(job: JobRecord, url: str, secret: str | None) -> CallbackRecord:
    """The webhook row of a new job: pending, due as soon as the job ends."""
    return CallbackRecord(
        job_id=job.id,
        owner=job.owner,
        url=url,
        secret=secret or None,
        status="pending",
        attempts=[],
        next_attempt_at=job.created_at,
        created_at=job.created_at,
    )


def _active_condition(owner: str) -> tuple[ColumnElement[bool], ColumnElement[bool]]:
    """The owner's queued or running jobs."""
    return JobRecord.owner == owner, JobRecord.state.in_(names.ACTIVE_STATES)


class JobRecordStore(StoreBase):
    """The job rows of a job store."""

    def create_job(
        self,
        *,
        owner: str,
        kind: str,
        params: dict[str, Any],
        idempotency_key: str | None = None,
        queued_lease_seconds: float = 900.0,
        max_active: int | None = None,
        callback: tuple[str, str | None] | None = None,
    ) -> tuple[JobView, bool]:
        """Create a queued job; returns (job, created). With an idempotency key
        already used by this owner, returns the existing job and False.

        ``max_active``: the most queued or running jobs the owner may have. The
        count and the insert are one atomic step (:func:`lock_owner_jobs`), so
        concurrent calls never admit more than ``max_active``; over the limit
        raises :class:`TooManyActiveJobs`. None: no limit.

        Under the same lock, every uploaded file the parameters name must still
        exist (:class:`InputGone` otherwise): the retention cleanup deletes
        uploads under that lock too, so a job never starts on a deleted input.

        ``callback``: ``(url, secret)`` of the job's webhook, stored with the job.
        """
        if idempotency_key is not None:
            existing = self.job_by_idempotency_key(owner, idempotency_key)
            if existing is not None:
                return existing, False
        row = _queued_job(owner, kind, params, idempotency_key, queued_lease_seconds)
        try:
            with self.session() as s:
                if max_active is not None or file_refs(params):
                    lock_owner_jobs(s, owner)
                    made = self._by_key(s, owner, idempotency_key)
                    if made is not None:  # the same key won the lock first
                        return JobView.of(made), False
                    gone = missing_inputs(s, owner, params)
                    if gone:
                        raise InputGone(gone)
                if max_active is not None:
                    active = count_rows(s, JobRecord, *_active_condition(owner))
                    if active >= max_active:
                        raise TooManyActiveJobs(owner, active, max_active)
                s.add(row)
                if callback is not None:
                    s.add(_callback_row(row, *callback))
        except IntegrityError:
            if idempotency_key is None:
                raise
            existing = self.job_by_idempotency_key(owner, idempotency_key)
            if existing is None:
                raise
            return existing, False
        return present(self.get_job(row.id)), True

    @staticmethod
    def _by_key(s: Session, owner: str, key: str | None) -> JobRecord | None:
        if key is None:
            return None
        return s.scalar(
            select(JobRecord).where(JobRecord.owner == owner, JobRecord.idempotency_key == key)
        )

    def job_by_idempotency_key(self, owner: str, key: str) -> JobView | None:
        with self.session() as s:
            r = self._by_key(s, owner, key)
            return JobView.of(r) if r else None

    def get_job(self, job_id: str, owner: str | None = None) -> JobView | None:
        """The job, or None when absent or (with ``owner``) owned by someone else.

        A plain Core SELECT (no ORM session): this is the hot read of the API.
        """
        with self.engine.connect() as c:
            row = c.execute(_JOB_BY_ID, {"job_id": job_id}).first()
        if row is None or (owner is not None and row.owner != owner):
            return None
        return view_of(JobView, row)

    def list_jobs(
        self,
        owner: str,
        *,
        state: str | None = None,
        limit: int = 50,
        offset: int = 0,
    ) -> tuple[list[JobView], int]:
        """A page of the owner's jobs, newest first, and the total count."""
        with self.session() as s:
            cond = [JobRecord.owner == owner]
            if state is not None:
                cond.append(JobRecord.state == state)
            total = count_rows(s, JobRecord, *cond)
            rows = s.scalars(newest_first(select(JobRecord).where(*cond), JobRecord, limit, offset))
            return [JobView.of(r) for r in rows], total

    def count_active(self, owner: str) -> int:
        """How many of the owner's jobs are queued or running."""
        with self.session() as s:
            return count_rows(s, JobRecord, *_active_condition(owner))

    def jobs_by_ids(self, ids: Sequence[str]) -> list[JobView]:
        with self.session() as s:
            return [
                JobView.of(r) for r in s.scalars(select(JobRecord).where(JobRecord.id.in_(ids)))
            ]

    def fail_job(
        self, job_id: str, error: dict[str, Any], *, release_idempotency_key: bool = False
    ) -> None:
        """End an active job as failed with ``error`` ({type, message, field, stage}).

        ``release_idempotency_key``: also free the job's Idempotency-Key, so that
        the same key can create a new job (for a job that was never sent to a
        worker, e.g. when the broker refused it).
        """
        extra: dict[str, Any] = {"idempotency_key": None} if release_idempotency_key else {}
        self._update_job(
            job_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            error=error,
            **extra,
            **ended(names.FAILED, time.time()),
        )

    def cancel_job(self, job_id: str, owner: str) -> JobView | None:
        """Cancel a queued or running job; returns the job after the change."""
        self._update_job(
            job_id,
            JobRecord.owner == owner,
            JobRecord.state.in_(names.ACTIVE_STATES),
            **ended(names.CANCELLED, time.time()),
        )
        return self.get_job(job_id, owner)

    def delete_job(self, job_id: str, owner: str) -> bool:
        with self.session() as s:
            r = s.get(JobRecord, job_id)
            if r is None or r.owner != owner:
                return False
            s.delete(r)
            s.execute(delete(CallbackRecord).where(CallbackRecord.job_id == job_id))
            return True
