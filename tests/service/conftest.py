"""In-process API fixtures: the app with its task client replaced by an in-process one.

:class:`InlineTaskClient` validates uploads by calling the worker's real
validation function in this process, and records submitted jobs instead of
sending them; a test runs a job's real stages with :func:`run_job_inline`
(the same code a worker runs, without a broker). End-to-end tests with real
worker processes live in ``tests/worker/test_integration.py``.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from conformorph.service.core.config import Settings
from conformorph.service.main import create_app
from conformorph.worker import stages
from conformorph.worker.job_runner import Runtime, StageOutcome, run_stage
from conformorph.worker.job_store import JobStore
from conformorph.worker.storage import LocalStorage, Storage


class InlineTaskClient:
    def __init__(self, storage: Storage) -> None:
        self.storage = storage
        self.submitted: list[tuple[str, list[str]]] = []
        self.cancelled: list[str] = []
        self.precomputed: list[tuple[str, str]] = []

    def validate_mesh(
        self, key: str, file_type: str, max_vertices: int, max_faces: int, timeout: float
    ) -> dict[str, Any]:
        return stages.validate_upload(
            self.storage, key, file_type, max_vertices=max_vertices, max_faces=max_faces
        )

    def validate_shape(
        self, key: str, timeout: float, max_points: int | None = None
    ) -> dict[str, Any]:
        return stages.validate_shape_upload(self.storage, key, max_points=max_points)

    def submit_job(self, job_id: str, stages_: list[str]) -> None:
        self.submitted.append((job_id, list(stages_)))

    def precompute_key(self, owner: str, mesh_id: str) -> None:
        self.precomputed.append((owner, mesh_id))

    def cancel(self, task_id: str) -> None:
        self.cancelled.append(task_id)

    def ping(self) -> bool:
        return True

    def validation_served(self) -> bool:
        return True


class Api:
    """The test client plus handles on what is behind it."""

    def __init__(self, tmp: Path, **overrides: Any) -> None:
        overrides.setdefault("open_mode_recheck_seconds", 0.0)
        self.settings = Settings(data_dir=tmp, **overrides)
        self.store = JobStore(self.settings.resolved_database_url)
        self.storage = LocalStorage(self.settings.resolved_storage_dir)
        self.tasks = InlineTaskClient(self.storage)
        self.app = create_app(
            self.settings, store=self.store, storage=self.storage, task_client=self.tasks
        )
        self.client = TestClient(self.app)
        self.runtime = Runtime(self.settings, self.store, self.storage, worker_id="test-worker")

    def upload(
        self, path: Path, headers: dict[str, str] | None = None, name: str | None = None
    ) -> Any:
        with open(path, "rb") as f:
            return self.client.post(
                "/v1/meshes", files={"file": (name or path.name, f.read())}, headers=headers or {}
            )

    def run_job(self, job_id: str) -> list[StageOutcome]:
        return run_job_inline(self.runtime, job_id)


def run_job_inline(rt: Runtime, job_id: str) -> list[StageOutcome]:
    """Run every remaining stage of a job in this process, as a worker would."""
    job = rt.store.get_job(job_id)
    if job is None:
        raise LookupError(job_id)
    outs = []
    for stage in job.stages:
        out = run_stage(
            rt, job_id, stage, stages.ALL_STAGE_BODIES[stage], task_id=f"inline-{stage}"
        )
        outs.append(out)
        if out.status not in ("ran", "done"):
            break
    return outs


@pytest.fixture
def api(tmp_path: Path) -> Iterator[Api]:
    a = Api(tmp_path)
    yield a
    a.client.close()
    a.store.dispose()


@pytest.fixture
def make_api(tmp_path: Path) -> Iterator[Any]:
    made: list[Api] = []

    def make(**overrides: Any) -> Api:
        a = Api(tmp_path / f"api{len(made)}", **overrides)
        made.append(a)
        return a

    yield make
    for a in made:
        a.client.close()
        a.store.dispose()
