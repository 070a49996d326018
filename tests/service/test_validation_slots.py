"""One key's slow validations cannot hold the others' (issue 30): a per-key limit on the
validation slots, and a hard budget the worker enforces on each validation message."""

from __future__ import annotations

import asyncio
import json
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from conformorph.service.errors import ApiError
from conformorph.service.task_client import AsyncTasks, CeleryTaskClient, PerKeyLimit
from conformorph.worker import names
from conformorph.worker.config import WorkerSettings


class TwoSlotWorkers:
    """Validations served by two worker processes in arrival order: a ``slow`` key's take
    ``slow_seconds``, the others' return at once (what the interactive worker does)."""

    def __init__(self, slow_seconds: float) -> None:
        self.slots = threading.Semaphore(2)
        self.slow_seconds = slow_seconds
        self.running: dict[str, int] = {}
        self.most: dict[str, int] = {}
        self.lock = threading.Lock()

    def validate_mesh(
        self, key: str, file_type: str, max_vertices: int, max_faces: int, timeout: float
    ) -> dict[str, Any]:
        owner = key.split("/")[1]
        with self.slots:
            with self.lock:
                self.running[owner] = self.running.get(owner, 0) + 1
                self.most[owner] = max(self.most.get(owner, 0), self.running[owner])
            time.sleep(self.slow_seconds if owner == "slow" else 0.01)
            with self.lock:
                self.running[owner] -= 1
        return {"ok": True, "report": {}}


def _tasks(client: Any, timeout: float) -> AsyncTasks:
    return AsyncTasks(
        client,
        validate_timeout=timeout,
        broker_timeout=1.0,
        validation_threads=16,
        validation_slots=2,
    )


def test_a_key_holds_at_most_all_slots_but_one() -> None:
    workers = TwoSlotWorkers(slow_seconds=1.5)
    tasks = _tasks(workers, timeout=4.0)

    async def upload(owner: str, k: int) -> tuple[str, float, str]:
        t0 = time.monotonic()
        try:
            await tasks.validate_mesh(f"uploads/{owner}/{k}.glb", "glb", 10, 10, owner=owner)
            outcome = "ok"
        except ApiError as exc:
            outcome = str(exc.status)
        return owner, time.monotonic() - t0, outcome

    async def scenario() -> list[tuple[str, float, str]]:
        slow = [asyncio.create_task(upload("slow", k)) for k in range(6)]
        await asyncio.sleep(0.2)  # the slow key's uploads arrived first
        fast = [asyncio.create_task(upload("fast", k)) for k in range(5)]
        return await asyncio.gather(*slow, *fast)

    try:
        results = asyncio.run(scenario())
    finally:
        tasks.close()
    fast = [r for r in results if r[0] == "fast"]
    assert all(outcome == "ok" for _, _, outcome in fast), results
    assert max(seconds for _, seconds, _ in fast) < 1.0, results
    assert workers.most["slow"] == 1  # never both slots
    # the slow key's later uploads waited their turn, past the deadline: 503, not a stall
    assert {o for o, _, outcome in results if outcome == "503"} <= {"slow"}


def test_per_key_limit_forgets_idle_keys() -> None:
    limit = PerKeyLimit(1)

    async def run() -> None:
        await limit.acquire("a")
        assert limit.held("a") == 1
        waiter = asyncio.create_task(limit.acquire("a"))
        await asyncio.sleep(0.01)
        assert not waiter.done()  # a second one of the same key waits
        await limit.acquire("b")  # another key does not
        limit.release("a")
        await waiter
        limit.release("a")
        limit.release("b")

    asyncio.run(run())
    assert limit._keys == {}
    with pytest.raises(ValueError):
        PerKeyLimit(0)


def test_a_validation_message_carries_its_hard_budget(tmp_path: Path) -> None:
    """No worker runs: the API answers 503, and the message it left on the (real, embedded)
    broker expires at the deadline and carries the hard time limit that kills the
    validation's process once it has run that long."""
    settings = WorkerSettings(data_dir=tmp_path)
    client = CeleryTaskClient(settings)
    with pytest.raises(ApiError) as info:
        client.validate_mesh("uploads/k/x.glb", "glb", 10, 10, timeout=0.3)
    assert info.value.status == 503
    queue = tmp_path / "broker" / "queue"
    (message,) = [p for p in queue.iterdir() if names.QUEUE_INTERACTIVE in p.name]
    headers = json.loads(message.read_text())["headers"]
    assert headers["task"] == names.VALIDATE_MESH
    assert headers["timelimit"][0] == pytest.approx(0.3)
    assert headers["expires"] is not None
