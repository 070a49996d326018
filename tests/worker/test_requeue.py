"""The job store's redelivery: expired leases are requeued once, hopeless jobs failed."""

from __future__ import annotations

import json
import time
from base64 import b64decode
from pathlib import Path

from conformorph.worker import names
from conformorph.worker.celery_app import create_celery_app
from conformorph.worker.config import WorkerSettings
from conformorph.worker.job_store import JobStore
from conformorph.worker.requeue import requeue_expired


def _queued_messages(settings: WorkerSettings) -> list[dict[str, object]]:
    out = []
    for p in sorted((settings.broker_dir / "queue").glob(f"*.{names.QUEUE_JOBS}.msg")):
        out.append(json.loads(p.read_text()))
    return out


def test_expired_running_job_is_requeued_from_its_stage(tmp_path: Path) -> None:
    settings = WorkerSettings(data_dir=tmp_path, max_attempts=2)
    store = JobStore(settings.resolved_database_url)
    app = create_celery_app(settings)
    job, _ = store.create_job(owner="a", kind=names.KIND_RECONSTRUCTION, params={})
    store.claim_stage(job.id, "conformal_map", "w1", 30, None)
    store.complete_stage(
        job.id, "conformal_map", "w1", seconds=0.1, artifacts={}, handoff_lease_seconds=60
    )
    store.claim_stage(job.id, "curvature", "w1", 0.05, None)  # w1 then dies
    assert requeue_expired(store, app, settings) == []  # lease still valid
    time.sleep(0.1)
    assert requeue_expired(store, app, settings) == [job.id]
    assert requeue_expired(store, app, settings) == []  # taken once
    msgs = _queued_messages(settings)
    assert len(msgs) == 1
    headers = msgs[0]["headers"]
    assert headers["task"] == names.STAGE_TASKS["curvature"]  # type: ignore[index]
    body = json.loads(b64decode(msgs[0]["body"]))  # type: ignore[arg-type]
    assert body[0] == [job.id]
    chain = body[2]["chain"]
    assert [c["task"] for c in chain] == [names.STAGE_TASKS["reconstruct"]]
    row = store.get_job(job.id)
    assert row is not None and row.state == "running" and row.requeues == 1
    store.dispose()


def test_job_losing_its_worker_too_often_is_failed(tmp_path: Path) -> None:
    settings = WorkerSettings(data_dir=tmp_path, max_attempts=2)
    store = JobStore(settings.resolved_database_url)
    app = create_celery_app(settings)
    job, _ = store.create_job(owner="a", kind=names.KIND_CONFORMAL_MAP, params={})
    for i in range(3):  # claimed 3 times = 1 stage + 2 retries, every worker lost
        store.claim_stage(job.id, "conformal_map", f"w{i}", 0.01, None)
        time.sleep(0.03)
    assert requeue_expired(store, app, settings) == []
    row = store.get_job(job.id)
    assert row is not None and row.state == "failed"
    assert row.error is not None and row.error["type"] == "worker_lost"
    store.dispose()


def test_waiting_jobs_are_sent_again_once_after_the_broker_returns(tmp_path: Path) -> None:
    """Issue 30, item 10: queued jobs and jobs between stages (no worker holds them) are
    sent again when the broker answers again; a running one is not, and a second
    requeuer (another worker) does not send them a second time."""
    from conformorph.worker.requeue import requeue_waiting

    settings = WorkerSettings(data_dir=tmp_path)
    store = JobStore(settings.resolved_database_url)
    app = create_celery_app(settings)
    queued, _ = store.create_job(owner="a", kind=names.KIND_CONFORMAL_MAP, params={})
    between, _ = store.create_job(owner="a", kind=names.KIND_RECONSTRUCTION, params={})
    store.claim_stage(between.id, "conformal_map", "w1", 30, None)
    store.complete_stage(
        between.id, "conformal_map", "w1", seconds=0.1, artifacts={}, handoff_lease_seconds=900
    )
    running, _ = store.create_job(owner="a", kind=names.KIND_CONFORMAL_MAP, params={})
    store.claim_stage(running.id, "conformal_map", "w2", 30, None)
    time.sleep(0.01)
    down = time.time()  # the last check that found the broker down
    assert sorted(requeue_waiting(store, app, settings, down)) == sorted([queued.id, between.id])
    # another worker's requeuer, which found the broker down at the same moment
    assert requeue_waiting(store, app, settings, down) == []
    sent = [json.loads(b64decode(m["body"]))[0][0] for m in _queued_messages(settings)]  # type: ignore[arg-type]
    assert sorted(sent) == sorted([queued.id, between.id])
    tasks = {m["headers"]["task"] for m in _queued_messages(settings)}  # type: ignore[index]
    assert names.STAGE_TASKS["curvature"] in tasks  # the job between stages goes on
    for jid in (queued.id, between.id):
        row = store.get_job(jid)
        assert row is not None and row.requeues == 1 and row.lease_until > down + 800
    store.dispose()
