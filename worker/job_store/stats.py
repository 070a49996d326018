"""Counts over the job rows for monitoring (read at scrape time by ``conformorph.service.metrics``).

Every host's workers write their jobs' stage durations (``stage_seconds``) and
errors into the shared job store, so the API can expose them for the whole
pool without any metrics state in the workers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from sqlalchemy import func, select

from conformorph.worker.job_store.base import StoreBase
from conformorph.worker.job_store.tables import JobRecord


@dataclass(frozen=True)
class JobStats:
    """A snapshot of the job rows.

    Attributes
    ----------
    by_kind_state : dict
        ``(kind, state)`` → number of jobs.
    stage_seconds : dict
        ``(kind, stage)`` → the durations in seconds of every finished run of
        that stage still on record.
    failures : dict
        ``(kind, stage, error type)`` → failed jobs (stage ``""`` when the error
        names none).
    """

    by_kind_state: dict[tuple[str, str], int] = field(default_factory=dict)
    stage_seconds: dict[tuple[str, str], list[float]] = field(default_factory=dict)
    failures: dict[tuple[str, str, str], int] = field(default_factory=dict)


class StatsStore(StoreBase):
    """Monitoring counts of a job store."""

    def job_stats(self) -> JobStats:
        """Jobs by kind and state, stage durations and failures by error type."""
        stats = JobStats()
        with self.session() as s:
            counted = s.execute(
                select(JobRecord.kind, JobRecord.state, func.count()).group_by(
                    JobRecord.kind, JobRecord.state
                )
            )
            for kind, state, n in counted:
                stats.by_kind_state[(kind, state)] = int(n)
            for kind, seconds in s.execute(select(JobRecord.kind, JobRecord.stage_seconds)):
                for stage, sec in (seconds or {}).items():
                    stats.stage_seconds.setdefault((kind, stage), []).append(float(sec))
            failed = select(JobRecord.kind, JobRecord.error).where(JobRecord.state == "failed")
            for kind, error in s.execute(failed):
                err = error or {}
                key = (kind, str(err.get("stage") or ""), str(err.get("type") or "unknown"))
                stats.failures[key] = stats.failures.get(key, 0) + 1
        return stats
