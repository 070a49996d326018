"""How the API talks to the workers: send tasks by name through a thin client app.

The API never imports task bodies or geometry. Upload validation runs in a
worker as a short synchronous task on its own queue
(``conformorph-interactive``), so the API process needs neither numpy's
numerics nor the geometry package, and a mesh is validated by exactly the code
the CLI uses. Jobs are sent as a chain of stage tasks (``worker.dispatch``).
"""

from __future__ import annotations

from typing import Any, Protocol

from celery.exceptions import TimeoutError as CeleryTimeout

from service.errors import ApiError
from worker import names
from worker.celery_app import create_celery_app
from worker.config import WorkerSettings
from worker.dispatch import send_job


class TaskClient(Protocol):
    """What the routes need from the worker side."""

    def validate_mesh(
        self, key: str, file_type: str, max_vertices: int, max_faces: int, timeout: float
    ) -> dict[str, Any]: ...

    def validate_shape(
        self, key: str, timeout: float, max_points: int | None = None
    ) -> dict[str, Any]: ...

    def submit_job(self, job_id: str, stages: list[str]) -> None: ...

    def cancel(self, task_id: str) -> None: ...

    def ping(self) -> bool: ...


class CeleryTaskClient:
    """:class:`TaskClient` over Celery (embedded filesystem broker or Redis)."""

    def __init__(self, settings: WorkerSettings) -> None:
        self.settings = settings
        self.app = create_celery_app(settings, include_tasks=False)

    def validate_mesh(
        self, key: str, file_type: str, max_vertices: int, max_faces: int, timeout: float
    ) -> dict[str, Any]:
        return self._call(names.VALIDATE_MESH, [key, file_type, max_vertices, max_faces], timeout)

    def validate_shape(
        self, key: str, timeout: float, max_points: int | None = None
    ) -> dict[str, Any]:
        return self._call(names.VALIDATE_SHAPE, [key, max_points], timeout)

    def _call(self, task: str, args: list[Any], timeout: float) -> dict[str, Any]:
        """Run a short task on the interactive queue and wait for its answer."""
        res = self.app.send_task(task, args=args, queue=names.QUEUE_INTERACTIVE)
        try:
            out = res.get(timeout=timeout, interval=0.02, propagate=True)
        except CeleryTimeout as exc:
            res.revoke()
            raise ApiError(
                503,
                "worker_unavailable",
                f"no worker answered within {timeout:g} s; is a worker running?",
            ) from exc
        except Exception as exc:  # noqa: BLE001 - the task itself crashed
            raise ApiError(503, "worker_error", f"the validation task failed: {exc}") from exc
        finally:
            res.forget()
        if not isinstance(out, dict):
            raise ApiError(503, "worker_error", "the validation worker gave no answer")
        return out

    def submit_job(self, job_id: str, stages: list[str]) -> None:
        send_job(self.app, job_id, stages)

    def cancel(self, task_id: str) -> None:
        # not terminate=True: killing the pool child races with billiard handing it
        # the next task; the running stage notices the cancellation itself
        # (worker.job_runner._LeaseKeeper) and stops within about a second
        self.app.control.revoke(task_id)

    def ping(self) -> bool:
        try:
            with self.app.connection_for_write() as conn:
                conn.ensure_connection(max_retries=1, timeout=2)
            return True
        except Exception:  # noqa: BLE001 - readiness probe reports any failure
            return False
