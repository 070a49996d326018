"""A job's life on the workers: stage claims under a lease, renewals, progress,
completed stages, and the takeover of jobs whose lease ran out (see the package
docstring of :mod:`conformorph.worker.job_store`)."""

from __future__ import annotations

import time
from typing import Any

from sqlalchemy import func, or_, select

from conformorph.worker import names
from conformorph.worker.job_store.jobs import JobRecordStore, ended
from conformorph.worker.job_store.tables import JobRecord
from conformorph.worker.job_store.views import Claim, JobView


class LeaseStore(JobRecordStore):
    """Stage leases on the job rows of a job store."""

    def claim_stage(
        self, job_id: str, stage: str, worker_id: str, lease_seconds: float, task_id: str | None
    ) -> Claim:
        """Take the job's lease to run ``stage`` (see :class:`Claim`)."""
        now = time.time()
        job = self.get_job(job_id)
        if job is None or job.state in names.TERMINAL_STATES:
            return Claim("gone", job)
        if stage in job.stages_done:
            return Claim("done", job)
        claimed = self._update_job(
            job_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            or_(
                JobRecord.lease_owner.is_(None),
                JobRecord.lease_until.is_(None),
                JobRecord.lease_until < now,
                JobRecord.lease_owner == worker_id,
            ),
            state=names.RUNNING,
            stage=stage,
            lease_owner=worker_id,
            lease_until=now + lease_seconds,
            task_id=task_id,
            attempts=JobRecord.attempts + 1,
            started_at=func.coalesce(JobRecord.started_at, now),
            updated_at=now,
        )
        job = self.get_job(job_id)
        if claimed:
            return Claim("claimed", job)
        if job is None or job.state in names.TERMINAL_STATES:
            return Claim("gone", job)
        wait = max(0.0, (job.lease_until or now) - now)
        return Claim("busy", job, wait)

    def renew_lease(self, job_id: str, worker_id: str, lease_seconds: float) -> bool:
        """Extend a held lease; False when it is no longer ours or the job ended."""
        return self._update_job(
            job_id,
            JobRecord.lease_owner == worker_id,
            JobRecord.state == names.RUNNING,
            lease_until=time.time() + lease_seconds,
        )

    def hand_back_lease(self, job_id: str, worker_id: str, hold_seconds: float) -> bool:
        """Give up a held lease for a retry that any worker process may pick up.

        The owner is cleared (so :meth:`claim_stage` succeeds for whoever gets the
        retried task), and the lease runs ``hold_seconds`` more, so the requeuer
        resends the stage only if that retry never comes. False when the lease was
        not ours. The claim is taken back from ``attempts`` (which counts claims lost with
        their worker: a job retried through a long storage outage is not "lost too often").
        """
        return self._update_job(
            job_id,
            JobRecord.lease_owner == worker_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            lease_owner=None,
            lease_until=time.time() + hold_seconds,
            attempts=JobRecord.attempts - 1,  # our claim counted one; it is at least 1
        )

    def set_progress(self, job_id: str, worker_id: str, progress: float) -> None:
        self._update_job(
            job_id,
            JobRecord.lease_owner == worker_id,
            progress=min(1.0, max(0.0, float(progress))),
            updated_at=time.time(),
        )

    def complete_stage(
        self,
        job_id: str,
        stage: str,
        worker_id: str,
        *,
        seconds: float,
        artifacts: dict[str, dict[str, Any]],
        handoff_lease_seconds: float,
    ) -> JobView | None:
        """Record a finished stage; the last stage makes the job ``succeeded``.

        Between stages the lease is released to nobody but kept alive for
        ``handoff_lease_seconds``, so a worker lost before the next stage
        starts is noticed.
        """
        now = time.time()
        with self.session() as s:
            r = s.get(JobRecord, job_id, with_for_update=True)
            if r is None or r.state in names.TERMINAL_STATES:
                return JobView.of(r) if r else None
            done = list(r.stages_done)
            if stage not in done:
                done.append(stage)
            r.stages_done = done
            r.stage_seconds = {**r.stage_seconds, stage: round(float(seconds), 4)}
            r.artifacts = {**r.artifacts, **artifacts}
            r.progress = len(done) / max(1, len(r.stages))
            r.updated_at = now
            if all(st in done for st in r.stages):
                for column, value in ended(names.SUCCEEDED, now).items():
                    setattr(r, column, value)
                r.progress = 1.0
            else:
                r.lease_owner = None
                r.lease_until = now + handoff_lease_seconds
            return JobView.of(r)

    def expired_jobs(self, now: float | None = None, limit: int = 20) -> list[str]:
        """Ids of active jobs whose lease has run out."""
        now = time.time() if now is None else now
        with self.session() as s:
            return list(
                s.scalars(
                    select(JobRecord.id)
                    .where(
                        JobRecord.state.in_(names.ACTIVE_STATES),
                        JobRecord.lease_until.is_not(None),
                        JobRecord.lease_until < now,
                    )
                    .order_by(JobRecord.lease_until)
                    .limit(limit)
                )
            )

    def waiting_jobs(self, before: float, limit: int = 500) -> list[str]:
        """Ids of active jobs no worker holds (queued, or between two stages) that
        nothing touched since ``before``: their message is in the broker, or lost."""
        with self.session() as s:
            return list(
                s.scalars(
                    select(JobRecord.id)
                    .where(
                        JobRecord.state.in_(names.ACTIVE_STATES),
                        JobRecord.lease_owner.is_(None),
                        JobRecord.updated_at < before,
                    )
                    .order_by(JobRecord.created_at)
                    .limit(limit)
                )
            )

    def take_waiting(self, job_id: str, before: float, grace_seconds: float) -> JobView | None:
        """Atomically take a waiting job (see :meth:`waiting_jobs`) to send it again:
        exactly one caller wins, and a job touched since ``before`` (claimed, or taken
        by another requeuer) is left alone."""
        now = time.time()
        taken = self._update_job(
            job_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            JobRecord.lease_owner.is_(None),
            JobRecord.updated_at < before,
            lease_until=now + grace_seconds,
            requeues=JobRecord.requeues + 1,
            updated_at=now,
        )
        return self.get_job(job_id) if taken else None

    def take_expired(self, job_id: str, grace_seconds: float) -> JobView | None:
        """Atomically take an expired job for requeueing (exactly one caller wins)."""
        now = time.time()
        taken = self._update_job(
            job_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            JobRecord.lease_until < now,
            lease_owner=None,
            lease_until=now + grace_seconds,
            requeues=JobRecord.requeues + 1,
            updated_at=now,
        )
        return self.get_job(job_id) if taken else None
