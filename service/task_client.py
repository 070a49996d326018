"""How the API talks to the workers: send tasks by name through a thin client app.

The API never imports task bodies or geometry. Upload validation runs in a
worker as a short synchronous task on its own queue
(``conformorph-interactive``), so the API process needs neither numpy's
numerics nor the geometry package, and a mesh is validated by exactly the code
the CLI uses. Jobs are sent as a chain of stage tasks (``conformorph.worker.dispatch``).

Every call that waits on the broker or the result store is bounded in
wall-clock time (issue 15): :class:`CeleryTaskClient` polls with a monotonic
deadline (Celery's own ``get(timeout=)`` counts only its sleeps) and retries a
lost connection at most briefly, and the routes reach it only through
:class:`AsyncTasks`, which runs validations and broker calls in thread pools of
their own (so that waiting uploads never take the threads status reads need)
under an ``asyncio`` deadline that counts the time queued for a thread too.
A wait past its deadline, or an outage, is a 503 with ``Retry-After``.
"""

from __future__ import annotations

import asyncio
import functools
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Any, Protocol, TypeVar

from conformorph.service.errors import ApiError
from conformorph.worker import names
from conformorph.worker.celery_app import create_celery_app
from conformorph.worker.config import WorkerSettings
from conformorph.worker.dispatch import send_job

_T = TypeVar("_T")
#: seconds a client is asked to wait before retrying after a 503
RETRY_AFTER = "5"
#: seconds between looks at a pending validation's result: the first, and at most
#: (the pause grows by half each time, so a long wait costs a few looks a second)
_POLL, _POLL_MAX = 0.02, 0.25
#: seconds an answer to "does a worker consume the validation queue" is reused: a yes
#: for SERVED_TTL, a no only for SERVED_NO_TTL, so that a server whose workers are still
#: starting says ready within about a second of the first worker answering (a no kept
#: for 5 s cost a freshly started ``conformorph serve`` up to 5 s of readiness)
SERVED_TTL = 5.0
SERVED_NO_TTL = 0.2
#: how often a lost broker or result-store connection is retried per call
_OUTAGE_RETRY = {"max_retries": 1, "interval_start": 0, "interval_step": 0.2, "interval_max": 0.2}


def unavailable(type_: str, message: str) -> ApiError:
    """A 503 ``type_`` with ``Retry-After``."""
    return ApiError(503, type_, message, headers={"Retry-After": RETRY_AFTER})


class TaskClient(Protocol):
    """What the routes need from the worker side (blocking calls; see :class:`AsyncTasks`)."""

    def validate_mesh(
        self, key: str, file_type: str, max_vertices: int, max_faces: int, timeout: float
    ) -> dict[str, Any]: ...

    def validate_shape(
        self, key: str, timeout: float, max_points: int | None = None
    ) -> dict[str, Any]: ...

    def submit_job(self, job_id: str, stages: list[str]) -> None: ...

    def precompute_key(self, owner: str, mesh_id: str) -> None: ...

    def cancel(self, task_id: str) -> None: ...

    def ping(self) -> bool: ...

    def validation_served(self) -> bool: ...


class _Waits:
    """When each validation still waiting for its answer began (monotonic seconds)."""

    def __init__(self) -> None:
        self._started: dict[int, float] = {}
        self._lock = threading.Lock()

    @contextmanager
    def waiting(self) -> Iterator[None]:
        token = object()
        with self._lock:
            self._started[id(token)] = time.monotonic()
        try:
            yield
        finally:
            with self._lock:
                self._started.pop(id(token), None)

    def longest(self) -> float:
        """Seconds the oldest unanswered validation has waited (0 when none waits)."""
        with self._lock:
            oldest = min(self._started.values(), default=None)
        return 0.0 if oldest is None else time.monotonic() - oldest


class CeleryTaskClient:
    """:class:`TaskClient` over Celery (embedded filesystem broker or Redis)."""

    def __init__(self, settings: WorkerSettings, *, broker_timeout: float = 10.0) -> None:
        self.settings, self.broker_timeout = settings, broker_timeout
        self.app = create_celery_app(settings, include_tasks=False)
        # an outage must not cost minutes of reconnecting: the API answers 503 instead
        conf = self.app.conf
        conf.task_publish_retry_policy = dict(_OUTAGE_RETRY)
        conf.broker_connection_timeout = min(4.0, broker_timeout)
        conf.broker_connection_max_retries = 1
        conf.result_backend_transport_options = {
            **(conf.result_backend_transport_options or {}),
            "retry_policy": dict(_OUTAGE_RETRY),
        }
        conf.redis_socket_connect_timeout = min(4.0, broker_timeout)
        conf.redis_socket_timeout = broker_timeout

    def validate_mesh(
        self, key: str, file_type: str, max_vertices: int, max_faces: int, timeout: float
    ) -> dict[str, Any]:
        return self._call(names.VALIDATE_MESH, [key, file_type, max_vertices, max_faces], timeout)

    def validate_shape(
        self, key: str, timeout: float, max_points: int | None = None
    ) -> dict[str, Any]:
        return self._call(names.VALIDATE_SHAPE, [key, max_points], timeout)

    def _call(self, task: str, args: list[Any], timeout: float) -> dict[str, Any]:
        """Run a short task on the interactive queue; wait for its answer at most
        ``timeout`` seconds of wall-clock time, sending included."""
        deadline = time.monotonic() + timeout
        try:
            # a hard budget the worker enforces: the task is dropped if it has not begun
            # by then (expires) and its pool process killed once it has run that long
            # (time_limit), so a validation never goes on after the API gave up
            res = self.app.send_task(
                task,
                args=args,
                queue=names.QUEUE_INTERACTIVE,
                expires=timeout,
                time_limit=timeout,
            )
        except Exception as exc:  # noqa: BLE001 - any broker failure: retry later
            raise unavailable("broker_unavailable", f"the broker refused: {exc}") from exc
        pause = _POLL
        try:
            while not res.ready():
                now = time.monotonic()
                if now >= deadline:
                    _best_effort(res.revoke)
                    raise unavailable(
                        "worker_unavailable",
                        f"no worker answered within {timeout:g} s; is a worker running?",
                    )
                time.sleep(min(pause, deadline - now))
                pause = min(pause * 1.5, _POLL_MAX)
            out = res.result
            if res.failed():
                raise unavailable("worker_error", f"the validation task failed: {out!r}")
        except ApiError:
            raise
        except Exception as exc:  # noqa: BLE001 - the result store failed
            raise unavailable(
                "result_store_unavailable", f"the result store failed: {exc}"
            ) from exc
        finally:
            _best_effort(res.forget)
        if not isinstance(out, dict):
            raise unavailable("worker_error", "the validation worker gave no answer")
        return out

    def submit_job(self, job_id: str, stages: list[str]) -> None:
        send_job(self.app, job_id, stages)

    def precompute_key(self, owner: str, mesh_id: str) -> None:
        self.app.send_task(names.PRECOMPUTE_KEY, args=[owner, mesh_id], queue=names.QUEUE_JOBS)

    def cancel(self, task_id: str) -> None:
        # not terminate=True: killing the pool child races with billiard handing it
        # the next task; the running stage notices the cancellation itself
        # (conformorph.worker.job_runner._LeaseKeeper) and stops within about a second
        self.app.control.revoke(task_id)

    def ping(self) -> bool:
        try:
            with self.app.connection_for_write() as conn:
                conn.ensure_connection(max_retries=1, timeout=2)
            return True
        except Exception:  # noqa: BLE001 - readiness probe reports any failure
            return False

    def validation_served(self) -> bool:
        """A live worker consumes the validation queue (asked with a 1 s timeout)."""
        try:
            queues = self.app.control.inspect(timeout=1.0).active_queues() or {}
        except Exception:  # noqa: BLE001 - readiness probe reports any failure
            return False
        return any(
            q.get("name") == names.QUEUE_INTERACTIVE for qs in queues.values() for q in qs or []
        )


def _best_effort(fn: Callable[[], object]) -> None:
    try:
        fn()
    except Exception:  # noqa: BLE001,S110 - cleanup only; the answer is already decided
        pass


class PerKeyLimit:
    """At most ``limit`` validations of one key at a time (asyncio, one event loop).

    Validation slots are few (``validation_slots`` worker processes); one key's
    uploads beyond ``limit`` wait here, in the API, instead of queueing ahead of
    other keys' uploads on the broker, so a key sending slow inputs holds at most
    ``limit`` slots and the others' uploads keep being validated.
    """

    def __init__(self, limit: int) -> None:
        if limit < 1:
            raise ValueError(f"limit must be at least 1, got {limit}")
        self.limit = limit
        self._keys: dict[str, tuple[asyncio.Semaphore, list[int]]] = {}

    async def acquire(self, owner: str) -> None:
        sem, users = self._keys.setdefault(owner, (asyncio.Semaphore(self.limit), [0]))
        users[0] += 1
        try:
            await sem.acquire()
        except BaseException:
            self._drop(owner)
            raise

    def release(self, owner: str) -> None:
        self._keys[owner][0].release()
        self._drop(owner)

    def _drop(self, owner: str) -> None:
        users = self._keys[owner][1]
        users[0] -= 1
        if users[0] == 0:  # nobody holds or waits: forget the key
            del self._keys[owner]

    def held(self, owner: str) -> int:
        """Validations of ``owner`` running now."""
        entry = self._keys.get(owner)
        return 0 if entry is None else self.limit - entry[0]._value


class AsyncTasks:
    """The routes' view of a :class:`TaskClient`: every call awaited, in its own
    bounded thread pool, under a wall-clock deadline (503 with ``Retry-After``
    beyond it). Validations and broker calls have separate pools, and neither is
    the pool that serves status reads."""

    def __init__(
        self,
        client: TaskClient,
        *,
        validate_timeout: float,
        broker_timeout: float,
        validation_threads: int,
        validation_slots: int = 2,
    ) -> None:
        self.client = client
        self._fair = PerKeyLimit(max(1, validation_slots - 1))
        self.validate_timeout, self.broker_timeout = validate_timeout, broker_timeout
        self._validations = ThreadPoolExecutor(validation_threads, "conformorph-validate")
        self._broker = ThreadPoolExecutor(4, "conformorph-broker")
        self.waits = _Waits()
        self._served: tuple[bool, float] = (False, -1e9)
        self._inspection: asyncio.Lock | None = None  # one worker inspection at a time

    async def _run(
        self, pool: ThreadPoolExecutor, timeout: float, what: str, fn: Callable[..., _T], *a: Any
    ) -> _T:
        fut = asyncio.get_running_loop().run_in_executor(pool, functools.partial(fn, *a))
        try:
            return await asyncio.wait_for(fut, timeout)
        except TimeoutError as exc:
            raise unavailable(
                "worker_unavailable" if pool is self._validations else "broker_unavailable",
                f"{what} did not finish within {timeout:g} s; retry later",
            ) from exc

    async def _validate(self, owner: str, what: str, fn: Callable[[float], _T]) -> _T:
        """``fn(seconds)`` under the per-key limit; the wait for this key's turn counts in
        ``validate_timeout`` (503 ``worker_unavailable`` beyond it)."""
        start = time.monotonic()
        with self.waits.waiting():
            try:
                async with asyncio.timeout(self.validate_timeout):
                    await self._fair.acquire(owner)
            except TimeoutError as exc:
                raise unavailable(
                    "worker_unavailable",
                    f"this key's earlier uploads hold its validation slots; {what} did not "
                    f"start within {self.validate_timeout:g} s; retry later",
                ) from exc
            try:
                left = max(0.1, self.validate_timeout - (time.monotonic() - start))
                return await self._run(self._validations, left + 0.5, what, fn, left)
            finally:
                self._fair.release(owner)

    async def validate_mesh(
        self, key: str, file_type: str, max_vertices: int, max_faces: int, *, owner: str = ""
    ) -> dict[str, Any]:
        return await self._validate(
            owner,
            "the mesh validation",
            lambda t: self.client.validate_mesh(key, file_type, max_vertices, max_faces, t),
        )

    async def validate_shape(
        self, key: str, max_points: int | None = None, *, owner: str = ""
    ) -> dict[str, Any]:
        return await self._validate(
            owner,
            "the shape validation",
            lambda t: self.client.validate_shape(key, t, max_points),
        )

    async def submit_job(self, job_id: str, stages: list[str]) -> None:
        await self._run(
            self._broker,
            self.broker_timeout,
            "sending the job",
            self.client.submit_job,
            job_id,
            stages,
        )

    async def precompute_key(self, owner: str, mesh_id: str) -> bool:
        """Send an uploaded mesh's precompute (best effort: False when the broker did not
        take it; a morph then computes the mesh's work itself)."""
        try:
            await self._run(
                self._broker,
                self.broker_timeout,
                "sending the precompute",
                self.client.precompute_key,
                owner,
                mesh_id,
            )
        except ApiError:
            return False
        except Exception:  # noqa: BLE001 - a broker failure: the morph computes it later
            return False
        return True

    async def cancel(self, task_id: str) -> None:
        await self._run(
            self._broker, self.broker_timeout, "cancelling the task", self.client.cancel, task_id
        )

    async def ping(self) -> bool:
        try:
            return await self._run(self._broker, 3.0, "the broker ping", self.client.ping)
        except ApiError:
            return False

    async def validation_served(self) -> bool:
        """A worker consumes the validation queue, and no validation here has
        waited longer than its timeout (a worker that is there but not keeping up)."""
        if self.waits.longest() > self.validate_timeout:
            return False
        # asking the workers takes a second (a broadcast collects replies until its
        # timeout): a yes is kept for SERVED_TTL seconds, a no for SERVED_NO_TTL, and
        # probes that arrive during an inspection wait for its answer
        fresh = self._fresh_served()
        if fresh is not None:
            return fresh
        if self._inspection is None:
            self._inspection = asyncio.Lock()
        async with self._inspection:
            fresh = self._fresh_served()
            if fresh is not None:
                return fresh
            try:
                value = await self._run(
                    self._broker, 3.0, "the worker inspection", self.client.validation_served
                )
            except ApiError:
                value = False
            self._served = (value, time.monotonic())
        return value

    def _fresh_served(self) -> bool | None:
        """The kept answer of :meth:`validation_served`, or None when it is stale."""
        value, at = self._served
        ttl = SERVED_TTL if value else SERVED_NO_TTL
        return value if time.monotonic() - at <= ttl else None

    def close(self) -> None:
        self._validations.shutdown(wait=False, cancel_futures=True)
        self._broker.shutdown(wait=False, cancel_futures=True)
