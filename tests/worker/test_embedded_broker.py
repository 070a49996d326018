"""The embedded broker's filesystem transport: messages appear whole and are taken once."""

from __future__ import annotations

import multiprocessing as mp
import os
import zlib
from pathlib import Path
from typing import Any

import pytest
from kombu import Connection

import conformorph.worker.embedded as embedded
from conformorph.worker.celery_app import create_celery_app
from conformorph.worker.config import WorkerSettings
from conformorph.worker.embedded import EMBEDDED_TRANSPORT, embedded_transport_options


def _queue_name(broker_dir: Path) -> str:
    """One queue name per test folder: kombu keeps declared exchanges in a
    process-wide state, so a name reused with a new folder would not be bound there."""
    return f"q{zlib.crc32(str(broker_dir).encode()):08x}"


def _connection(broker_dir: Path) -> Connection:
    opts = embedded_transport_options(broker_dir, 0.01)
    return Connection("filesystem://", transport=EMBEDDED_TRANSPORT, transport_options=opts)


def test_the_embedded_app_uses_the_atomic_transport(tmp_path: Path) -> None:
    app = create_celery_app(WorkerSettings(data_dir=tmp_path))
    with app.connection_for_write() as conn:
        assert isinstance(conn.transport, embedded.Transport)
        assert conn.default_channel.__class__ is embedded.Channel


def test_a_message_is_in_the_queue_only_once_it_is_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    queue = tmp_path / "queue"
    seen: list[tuple[list[str], bytes]] = []
    real_replace = os.replace

    def replace(src: Any, dst: Any) -> None:
        # the moment before the message appears: the queue is still empty and
        # the staged file already holds the whole message
        seen.append((os.listdir(queue), Path(src).read_bytes()))
        real_replace(src, dst)

    with _connection(tmp_path) as conn:
        q = conn.SimpleQueue(_queue_name(tmp_path))
        monkeypatch.setattr(embedded.os, "replace", replace)
        q.put({"job": "abc"})
        monkeypatch.undo()
        assert seen[0][0] == [] and b'"delivery_tag"' in seen[0][1]
        assert os.listdir(tmp_path / "staging") == []
        assert q.get(timeout=1).payload == {"job": "abc"}
        assert os.listdir(queue) == [] and os.listdir(tmp_path / "processed") == []
        q.close()


def test_a_message_being_written_is_not_taken(tmp_path: Path) -> None:
    """A half-written file (kombu's own transport shows one under its final name)
    stays out of the queue: the consumer finds nothing rather than an empty message."""
    with _connection(tmp_path) as conn:
        q = conn.SimpleQueue(_queue_name(tmp_path))
        (tmp_path / "staging" / f"1_x.{_queue_name(tmp_path)}.msg.part").write_bytes(b"")
        with pytest.raises(q.Empty):
            q.get(timeout=0.2)
        q.close()


def test_two_consumers_take_a_message_once(tmp_path: Path) -> None:
    with _connection(tmp_path) as a, _connection(tmp_path) as b:
        qa, qb = a.SimpleQueue(_queue_name(tmp_path)), b.SimpleQueue(_queue_name(tmp_path))
        qa.put({"n": 1})
        name = os.listdir(tmp_path / "queue")[0]
        # b's channel renames the file first; a then finds it gone and skips it
        os.rename(tmp_path / "queue" / name, tmp_path / "processed" / name)
        with pytest.raises(qa.Empty):
            qa.get(timeout=0.1)
        os.rename(tmp_path / "processed" / name, tmp_path / "queue" / name)
        assert qb.get(timeout=1).payload == {"n": 1}
        with pytest.raises(qa.Empty):
            qa.get(timeout=0.1)
        qa.close()
        qb.close()


def _produce(broker_dir: Path, n: int) -> None:
    with _connection(broker_dir) as conn:
        q = conn.SimpleQueue(_queue_name(broker_dir))
        for i in range(n):
            q.put({"i": i})
        q.close()


def test_concurrent_producers_lose_no_message(tmp_path: Path) -> None:
    n = 300
    procs = [mp.get_context("spawn").Process(target=_produce, args=(tmp_path, n)) for _ in range(2)]
    for p in procs:
        p.start()
    got: list[int] = []
    with _connection(tmp_path) as conn:
        q = conn.SimpleQueue(_queue_name(tmp_path))
        while len(got) < 2 * n:
            try:
                m = q.get(timeout=20)
            except q.Empty:
                break
            m.ack()
            got.append(m.payload["i"])
        q.close()
    for p in procs:
        p.join(timeout=30)
    assert sorted(got) == sorted(list(range(n)) * 2)


def test_the_redis_transport_gets_a_short_restore_mutex_expiry() -> None:
    """A worker SIGKILLed inside a restore scan leaves kombu's mutex behind; with
    kombu's 300 s expiry no worker would restore a lost task for five minutes."""
    settings = WorkerSettings(broker_url="redis://127.0.0.1:1/0")
    app = create_celery_app(settings)
    opts = app.conf.broker_transport_options
    assert opts["unacked_mutex_expire"] == settings.redis_unacked_mutex_expire <= 30
    assert app.conf.broker_transport is None  # Redis: kombu's own transport


def test_the_queue_is_polled_fast_only_after_a_message(tmp_path: Path) -> None:
    """Idle: every ``polling_interval``; within ``busy_seconds`` of a delivery: every
    ``busy_polling_interval`` (the next stage of a job waits ms, not tens of ms)."""
    opts = embedded_transport_options(tmp_path, 0.05)
    assert opts["busy_polling_interval"] == embedded.BUSY_POLLING_INTERVAL < 0.05
    with Connection("filesystem://", transport=EMBEDDED_TRANSPORT, transport_options=opts) as c:
        t = c.transport
        assert t.polling_interval_now(100.0) == 0.05  # nothing delivered yet
        t._last_delivery = 100.0
        assert t.polling_interval_now(100.0 + 1.0) == embedded.BUSY_POLLING_INTERVAL
        assert t.polling_interval_now(100.0 + embedded.BUSY_SECONDS + 0.1) == 0.05
    # a busy interval above the idle one is never used
    slow = embedded_transport_options(tmp_path, 0.001)
    assert slow["busy_polling_interval"] == 0.001


def test_a_second_message_is_taken_at_the_busy_interval(tmp_path: Path) -> None:
    """With a 1 s idle interval, a message sent while the consumer waits, right after
    one it took, arrives within a fraction of that second."""
    import threading
    import time

    opts = embedded_transport_options(tmp_path, 1.0)
    with (
        _connection(tmp_path) as producer,
        Connection(
            "filesystem://", transport=EMBEDDED_TRANSPORT, transport_options=opts
        ) as consumer,
    ):
        name = _queue_name(tmp_path)
        qp, qc = producer.SimpleQueue(name), consumer.SimpleQueue(name)
        qp.put({"n": 1})
        assert qc.get(timeout=3).payload == {"n": 1}
        timer = threading.Timer(0.3, lambda: qp.put({"n": 2}))
        timer.start()
        t0 = time.monotonic()
        msg = qc.get(timeout=3)
        waited = time.monotonic() - t0
        timer.join()
        assert msg.payload == {"n": 2}
        # sent at 0.3 s; the idle interval would have looked again only at 1.0 s
        assert waited < 0.8, waited
        qp.close()
        qc.close()
