"""The one Celery app of conformorph, built from :class:`worker.config.WorkerSettings`.

``create_celery_app(settings, include_tasks=False)`` is the thin client the
API uses to send tasks by name (it never imports task bodies or geometry);
the worker process builds it with ``include_tasks=True``. ``celery -A
worker.celery_app worker`` also works: the module attribute ``app`` is created
on first access from the environment.
"""

from __future__ import annotations

from typing import Any

from celery import Celery

from worker import names
from worker.config import WorkerSettings, get_worker_settings
from worker.embedded import EMBEDDED_TRANSPORT, embedded_transport_options


def celery_config(settings: WorkerSettings) -> dict[str, Any]:
    """Celery settings: JSON only, late acks, prefetch 1, time limits, routes."""
    routes: dict[str, dict[str, str]] = {
        names.VALIDATE_MESH: {"queue": names.QUEUE_INTERACTIVE},
        names.VALIDATE_SHAPE: {"queue": names.QUEUE_INTERACTIVE},
    }
    for task in names.STAGE_TASKS.values():
        routes[task] = {"queue": names.QUEUE_JOBS}
    if settings.is_embedded:
        transport = embedded_transport_options(
            settings.broker_dir, settings.embedded_polling_interval
        )
    else:
        # redelivery of unacknowledged messages after a lost worker; longer than
        # the hard time limit so that a slow task is not run twice (celery #5306)
        transport = {
            "visibility_timeout": settings.redis_visibility_timeout,
            "unacked_restore_interval": settings.redis_restore_interval,
            "unacked_restore_throttle": 1,
            "unacked_mutex_expire": settings.redis_unacked_mutex_expire,
        }
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    return {
        "broker_url": settings.resolved_broker_url,
        "broker_transport": EMBEDDED_TRANSPORT if settings.is_embedded else None,
        "result_backend": settings.resolved_result_backend,
        "broker_transport_options": transport,
        "result_backend_transport_options": (
            {}
            if settings.is_embedded
            else {"visibility_timeout": settings.redis_visibility_timeout}
        ),
        "broker_connection_retry_on_startup": True,
        "task_serializer": "json",
        "result_serializer": "json",
        "accept_content": ["json"],
        "task_acks_late": True,
        "task_reject_on_worker_lost": False,
        "worker_prefetch_multiplier": 1,
        "task_soft_time_limit": settings.task_soft_time_limit,
        "task_time_limit": settings.task_hard_time_limit,
        "result_expires": settings.result_expires_seconds,
        "task_default_queue": names.QUEUE_JOBS,
        "task_routes": routes,
        "task_track_started": False,
        "worker_send_task_events": False,
        "worker_hijack_root_logger": False,
        "enable_utc": True,
    }


def create_celery_app(settings: WorkerSettings, *, include_tasks: bool = False) -> Celery:
    """A configured app; with ``include_tasks`` the worker's task modules are loaded."""
    app = Celery(
        "conformorph",
        include=["worker.tasks"] if include_tasks else [],
        set_as_current=include_tasks,
    )
    app.conf.update(celery_config(settings))
    return app


_app: Celery | None = None


def get_app() -> Celery:
    """The worker app configured from the environment (created once)."""
    global _app
    if _app is None:
        _app = create_celery_app(get_worker_settings(), include_tasks=True)
    return _app


def __getattr__(name: str) -> Any:
    if name in ("app", "celery"):
        return get_app()
    raise AttributeError(name)
