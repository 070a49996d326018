"""``/readyz``'s "a worker serves validations": a yes kept SERVED_TTL, a no only
SERVED_NO_TTL, one inspection at a time (service/task_client.py AsyncTasks)."""

from __future__ import annotations

import asyncio
import threading
import time
from typing import Any

from conformorph.service import task_client
from conformorph.service.task_client import SERVED_NO_TTL, SERVED_TTL, AsyncTasks


class _Workers:
    """Answers the inspection from ``answers`` in turn, counting the calls."""

    def __init__(self, answers: list[bool], delay: float = 0.0) -> None:
        self.answers, self.delay, self.calls = list(answers), delay, 0
        self._lock = threading.Lock()

    def validation_served(self) -> bool:
        with self._lock:
            self.calls += 1
            value = self.answers.pop(0) if len(self.answers) > 1 else self.answers[0]
        time.sleep(self.delay)
        return value

    def __getattr__(self, name: str) -> Any:
        raise AssertionError(f"unexpected call {name}")


def _tasks(workers: _Workers) -> AsyncTasks:
    return AsyncTasks(workers, validate_timeout=5.0, broker_timeout=5.0, validation_threads=1)  # type: ignore[arg-type]


def test_the_no_is_kept_briefly_and_the_yes_long():
    assert SERVED_NO_TTL < 1.0 < SERVED_TTL
    workers = _Workers([False, True])
    tasks = _tasks(workers)

    async def probes() -> list[bool]:
        first = await tasks.validation_served()
        again = await tasks.validation_served()  # within the no's TTL: not asked again
        await asyncio.sleep(SERVED_NO_TTL + 0.05)
        later = await tasks.validation_served()  # the worker has started since
        kept = await tasks.validation_served()
        return [first, again, later, kept]

    try:
        assert asyncio.run(probes()) == [False, False, True, True]
        assert workers.calls == 2
    finally:
        tasks.close()


def test_probes_during_an_inspection_share_its_answer(monkeypatch):
    monkeypatch.setattr(task_client, "SERVED_NO_TTL", 0.0)
    workers = _Workers([True], delay=0.3)
    tasks = _tasks(workers)

    async def probes() -> list[bool]:
        return list(await asyncio.gather(*(tasks.validation_served() for _ in range(5))))

    try:
        assert asyncio.run(probes()) == [True] * 5
        assert workers.calls == 1
    finally:
        tasks.close()
