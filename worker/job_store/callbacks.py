"""Job webhooks in the job store: the callback row of a job, the sweep that finds
callbacks due (their job ended, or a retry is late), and the record of each attempt.

The row is written with the job (:meth:`JobRecordStore.create_job`). Any worker's
requeuer thread sweeps for due callbacks and takes each with one conditional
UPDATE (pushing ``next_attempt_at`` on), so exactly one sweeper sends the
delivery task; a delivery task lost with its worker is sent again once that
hold runs out.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from sqlalchemy import select, update

from conformorph.worker import names
from conformorph.worker.job_store.base import StoreBase
from conformorph.worker.job_store.tables import CallbackRecord, JobRecord
from conformorph.worker.job_store.views import view_of

#: callback statuses
PENDING, DELIVERED, FAILED = "pending", "delivered", "failed"


@dataclass(frozen=True)
class CallbackView:
    """A detached copy of a job's callback row (``secret`` is for signing only: never
    put it in an answer)."""

    job_id: str
    owner: str
    url: str
    secret: str | None
    status: str
    attempts: list[dict[str, Any]]
    next_attempt_at: float
    created_at: float


class CallbackStore(StoreBase):
    """The webhook rows of a job store."""

    def get_callback(self, job_id: str) -> CallbackView | None:
        with self.session() as s:
            r = s.get(CallbackRecord, job_id)
            return view_of(CallbackView, r) if r else None

    def due_callbacks(self, now: float | None = None, limit: int = 50) -> list[str]:
        """Job ids whose callback is pending and due, and whose job has ended."""
        now = time.time() if now is None else now
        with self.session() as s:
            return list(
                s.scalars(
                    select(CallbackRecord.job_id)
                    .join(JobRecord, JobRecord.id == CallbackRecord.job_id)
                    .where(
                        CallbackRecord.status == PENDING,
                        CallbackRecord.next_attempt_at <= now,
                        JobRecord.state.in_(names.TERMINAL_STATES),
                    )
                    .order_by(CallbackRecord.next_attempt_at)
                    .limit(limit)
                )
            )

    def take_callback(self, job_id: str, hold_seconds: float) -> bool:
        """Take a due callback for sending (exactly one caller wins): it is not due
        again for ``hold_seconds`` unless its delivery task records a retry."""
        now = time.time()
        with self.session() as s:
            res = s.execute(
                update(CallbackRecord)
                .where(
                    CallbackRecord.job_id == job_id,
                    CallbackRecord.status == PENDING,
                    CallbackRecord.next_attempt_at <= now,
                )
                .values(next_attempt_at=now + hold_seconds)
                .execution_options(synchronize_session=False)
            )
            return bool(res.rowcount == 1)  # type: ignore[attr-defined]

    def record_callback_attempt(
        self, job_id: str, attempt: dict[str, Any], *, status: str, next_attempt_at: float
    ) -> CallbackView | None:
        """Append ``attempt`` to the callback's record and set its status (``pending``
        with the time the retry is due, ``delivered`` or ``failed``)."""
        with self.session() as s:
            r = s.get(CallbackRecord, job_id, with_for_update=True)
            if r is None:
                return None
            r.attempts = [*r.attempts, attempt]
            r.status = status
            r.next_attempt_at = next_attempt_at
            return view_of(CallbackView, r)
