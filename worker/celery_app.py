"""The one Celery app of conformorph, built from :class:`conformorph.worker.config.WorkerSettings`.

Brokers: the embedded filesystem broker (no URL), Redis or RabbitMQ. Every one
runs with late acknowledgement and prefetch 1, so a message stays with the
broker until its stage ends. A worker lost as a whole (SIGKILL, machine gone)
leaves its message unacknowledged: RabbitMQ requeues it as soon as the
connection drops, Redis after its visibility timeout, and the job store's lease
requeue resends it in every set-up. A pool child lost alone is not rejected
back to the broker (``task_reject_on_worker_lost`` off): the job store's lease
requeue resends that stage, bounded by ``max_attempts``, so a stage that kills
its process cannot loop through the broker forever.

``create_celery_app(settings, include_tasks=False)`` is the thin client the
API uses to send tasks by name (it never imports task bodies or geometry);
the worker process builds it with ``include_tasks=True``. ``celery -A
conformorph.worker.celery_app worker`` also works: the module attribute ``app`` is created
on first access from the environment.
"""

from __future__ import annotations

from typing import Any

from celery import Celery

from conformorph.worker import names
from conformorph.worker.config import WorkerSettings, get_worker_settings
from conformorph.worker.embedded import EMBEDDED_TRANSPORT, embedded_transport_options

#: seconds a stage's message may wait unacknowledged besides its run (the pool hand-over,
#: a retry's countdown) before RabbitMQ's consumer timeout
AMQP_CONSUMER_TIMEOUT_MARGIN = 60.0


def _transport_options(settings: WorkerSettings) -> dict[str, Any]:
    """``broker_transport_options`` for the embedded broker, RabbitMQ or Redis."""
    if settings.is_embedded:
        return embedded_transport_options(settings.broker_dir, settings.embedded_polling_interval)
    if settings.is_amqp:
        limit = settings.amqp_consumer_timeout - AMQP_CONSUMER_TIMEOUT_MARGIN
        if settings.task_hard_time_limit > limit:
            raise ValueError(
                f"task_hard_time_limit ({settings.task_hard_time_limit:g} s) must stay "
                f"{AMQP_CONSUMER_TIMEOUT_MARGIN:g} s below RabbitMQ's consumer_timeout "
                f"(amqp_consumer_timeout = {settings.amqp_consumer_timeout:g} s): a late-acked "
                "stage running longer gets its channel closed; raise the server's "
                "consumer_timeout and CONFORMORPH_AMQP_CONSUMER_TIMEOUT together"
            )
        return {}  # RabbitMQ redelivers on connection loss: no visibility timeout
    # redelivery of unacknowledged messages after a lost worker; longer than
    # the hard time limit so that a slow task is not run twice (celery #5306)
    return {
        "visibility_timeout": settings.redis_visibility_timeout,
        "unacked_restore_interval": settings.redis_restore_interval,
        "unacked_restore_throttle": 1,
        "unacked_mutex_expire": settings.redis_unacked_mutex_expire,
    }


def celery_config(settings: WorkerSettings) -> dict[str, Any]:
    """Celery settings: JSON only, late acks, prefetch 1, time limits, routes."""
    routes: dict[str, dict[str, str]] = {
        names.VALIDATE_MESH: {"queue": names.QUEUE_INTERACTIVE},
        names.VALIDATE_SHAPE: {"queue": names.QUEUE_INTERACTIVE},
        names.DELIVER_CALLBACK: {"queue": names.QUEUE_WEBHOOKS},
        names.CLEANUP: {"queue": names.QUEUE_INTERACTIVE},
    }
    for task in names.STAGE_TASKS.values():
        routes[task] = {"queue": names.QUEUE_JOBS}
    transport = _transport_options(settings)
    redis = not settings.is_embedded and not settings.is_amqp
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    return {
        "broker_url": settings.resolved_broker_url,
        "broker_transport": EMBEDDED_TRANSPORT if settings.is_embedded else None,
        "result_backend": settings.resolved_result_backend,
        "broker_transport_options": transport,
        "result_backend_transport_options": (
            {"visibility_timeout": settings.redis_visibility_timeout} if redis else {}
        ),
        "broker_connection_retry_on_startup": True,
        "task_serializer": "json",
        "result_serializer": "json",
        "accept_content": ["json"],
        "task_acks_late": True,
        "task_reject_on_worker_lost": False,
        "worker_prefetch_multiplier": 1,
        # RabbitMQ requeues a lost connection's unacknowledged messages at once (another
        # worker may take them): stop the late-acked stages still running here, whose
        # acknowledgement could no longer reach the broker (Celery 6's default)
        "worker_cancel_long_running_tasks_on_connection_loss": settings.is_amqp,
        "task_soft_time_limit": settings.task_soft_time_limit,
        "task_time_limit": settings.task_hard_time_limit,
        "result_expires": settings.result_expires_seconds,
        "task_default_queue": names.QUEUE_JOBS,
        "task_routes": routes,
        "task_track_started": False,
        "worker_send_task_events": False,
        "worker_hijack_root_logger": False,
        "enable_utc": True,
        # `conformorph worker --beat` (or `celery beat`) sends the retention cleanup;
        # the embedded set-up has `conformorph serve`'s timer instead
        "beat_schedule": {
            "conformorph-cleanup": {
                "task": names.CLEANUP,
                "schedule": settings.cleanup_interval_seconds,
                "options": {"queue": names.QUEUE_INTERACTIVE},
            }
        },
        "beat_schedule_filename": str(settings.data_dir / "celerybeat-schedule"),
    }


def create_celery_app(settings: WorkerSettings, *, include_tasks: bool = False) -> Celery:
    """A configured app; with ``include_tasks`` the worker's task modules are loaded."""
    app = Celery(
        "conformorph",
        include=["conformorph.worker.tasks"] if include_tasks else [],
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
