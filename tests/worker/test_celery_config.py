"""Tests of conformorph.worker.celery_app.celery_config per broker: embedded, Redis, RabbitMQ."""

from __future__ import annotations

from pathlib import Path

import pytest

from conformorph.worker.celery_app import AMQP_CONSUMER_TIMEOUT_MARGIN, celery_config
from conformorph.worker.config import WorkerSettings


def _settings(tmp_path: Path, **kw: object) -> WorkerSettings:
    return WorkerSettings(data_dir=tmp_path, **kw)  # type: ignore[arg-type]


def test_every_broker_acks_late_with_prefetch_one(tmp_path):
    for url in (None, "redis://127.0.0.1:6379/0", "amqp://guest:guest@127.0.0.1:5672//"):
        conf = celery_config(_settings(tmp_path, broker_url=url))
        assert conf["task_acks_late"] is True and conf["worker_prefetch_multiplier"] == 1
        assert conf["task_reject_on_worker_lost"] is False  # the job store's lease requeues


def test_rabbitmq_results_in_the_database_and_no_redis_options(tmp_path):
    s = _settings(tmp_path, broker_url="amqp://guest:guest@127.0.0.1:5672//")
    assert s.is_amqp and not s.is_embedded
    conf = celery_config(s)
    assert conf["broker_url"] == "amqp://guest:guest@127.0.0.1:5672//"
    assert conf["broker_transport"] is None
    assert conf["result_backend"] == f"db+sqlite:///{tmp_path / 'celery-results.sqlite'}"
    assert conf["broker_transport_options"] == {}
    assert conf["result_backend_transport_options"] == {}
    assert conf["worker_cancel_long_running_tasks_on_connection_loss"] is True
    # a server job store is shared by every host: the results go there too
    pg = "postgresql+psycopg://u:p@db:5432/conformorph"
    conf = celery_config(_settings(tmp_path, broker_url="amqp://h//", database_url=pg))
    assert conf["result_backend"] == "db+" + pg
    # an explicit result backend wins
    conf = celery_config(_settings(tmp_path, broker_url="amqp://h//", result_backend="rpc://"))
    assert conf["result_backend"] == "rpc://"


def test_redis_and_embedded_unchanged(tmp_path):
    conf = celery_config(_settings(tmp_path, broker_url="redis://127.0.0.1:6379/0"))
    assert conf["result_backend"] == "redis://127.0.0.1:6379/0"
    assert conf["broker_transport_options"]["visibility_timeout"] == 3600.0
    assert conf["result_backend_transport_options"] == {"visibility_timeout": 3600.0}
    assert conf["worker_cancel_long_running_tasks_on_connection_loss"] is False
    conf = celery_config(_settings(tmp_path))
    assert conf["result_backend"].startswith("db+sqlite:///")
    assert conf["result_backend_transport_options"] == {}
    assert "visibility_timeout" not in conf["broker_transport_options"]


def test_hard_time_limit_must_fit_below_rabbitmq_consumer_timeout(tmp_path):
    url = "amqp://guest:guest@127.0.0.1:5672//"
    fits = 1800.0 - AMQP_CONSUMER_TIMEOUT_MARGIN
    celery_config(_settings(tmp_path, broker_url=url, task_hard_time_limit=fits))
    with pytest.raises(ValueError, match="consumer_timeout"):
        celery_config(_settings(tmp_path, broker_url=url, task_hard_time_limit=fits + 1))
    # raised together with the server's consumer_timeout, it fits again
    celery_config(
        _settings(
            tmp_path, broker_url=url, task_hard_time_limit=7200.0, amqp_consumer_timeout=7500.0
        )
    )
    # Redis has no consumer timeout: any hard limit is fine there
    celery_config(_settings(tmp_path, broker_url="redis://h:6379/0", task_hard_time_limit=1e5))
