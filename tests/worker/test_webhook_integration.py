"""Webhooks and the retention cleanup end to end, with a real worker process on the
embedded broker and on Redis: the worker (not the API) POSTs the ended job to a
real receiver on 127.0.0.1, retries it after failures, and runs the cleanup task."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest

from conformorph.worker import names
from conformorph.worker.callbacks import SIGNATURE_HEADER, TIMESTAMP_HEADER, verify_signature
from tests.webhook_receiver import webhook_receiver
from tests.worker.test_integration import Service, _env

pytestmark = pytest.mark.timeout(300)

SECRET = "an end-to-end webhook secret"
HOOKS = {
    "CONFORMORPH_CALLBACK_ALLOW": "public,127.0.0.1/32",
    "CONFORMORPH_CALLBACK_BACKOFF_SECONDS": "0.2",
    "CONFORMORPH_JOB_RETENTION_SECONDS": "1",
}


def _webhooks_and_cleanup(svc: Service, small_face_path: Path) -> None:
    mesh = svc.upload(small_face_path)
    with webhook_receiver([503, 500]) as rx:
        job_id = svc.submit(
            "/v1/conformal-maps",
            {"mesh": mesh, "callback_url": rx.url, "callback_secret": SECRET},
        )
        got = rx.wait_for(3, timeout=120)
        time.sleep(1.5)  # a duplicate would come within the sweeps of this pause
        assert len(rx.requests) == 3
    for r in got:
        h = r.headers
        assert verify_signature(SECRET, h[TIMESTAMP_HEADER], r.body, h[SIGNATURE_HEADER])
        body = json.loads(r.body)
        assert body["id"] == job_id and body["state"] == "succeeded"
    assert got[1].at - got[0].at >= 0.2 and got[2].at - got[1].at >= 0.4  # back-off
    job = svc.client.get(f"/v1/jobs/{job_id}").json()
    cb = job["callback"]
    assert cb["status"] == "delivered" and cb["signed"] is True
    assert [a["status_code"] for a in cb["attempts"]] == [503, 500, 200]
    assert SECRET not in json.dumps(job)
    # the retention cleanup, sent as beat (or serve's timer) sends it, run by the worker
    time.sleep(1.1)  # the job ended more than CONFORMORPH_JOB_RETENTION_SECONDS ago
    app = svc.client.app.state.task_client.app  # type: ignore[attr-defined]
    app.send_task(names.CLEANUP, queue=names.QUEUE_INTERACTIVE)
    deadline = time.monotonic() + 60
    while svc.client.get(f"/v1/jobs/{job_id}").status_code != 404:
        assert time.monotonic() < deadline, "the cleanup did not delete the finished job"
        time.sleep(0.2)
    # the pass adds its totals at its end, after the job's row is gone and the uploads
    # are swept: its count must come to exactly this one job
    while (jobs := svc.store.cleanup_totals()["jobs"]) != 1:
        assert time.monotonic() < deadline, f"the cleanup counted {jobs} jobs, not 1"
        time.sleep(0.2)
    assert not any(svc.settings.resolved_storage_dir.glob(f"jobs/{job_id}/**/*.npz"))


def test_embedded_webhooks_and_cleanup(
    tmp_path: Path, start_worker: Any, small_face_path: Path
) -> None:
    env = _env(tmp_path, **HOOKS)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    svc.ready()
    _webhooks_and_cleanup(svc, small_face_path)


@pytest.mark.redis
def test_redis_webhooks_and_cleanup(
    tmp_path: Path, start_worker: Any, small_face_path: Path, redis_url: str
) -> None:
    env = _env(tmp_path, CONFORMORPH_BROKER_URL=redis_url, **HOOKS)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    svc.ready()
    _webhooks_and_cleanup(svc, small_face_path)


def test_a_trickling_receiver_holds_neither_uploads_nor_an_attempt_past_its_deadline(
    tmp_path: Path, start_worker: Any, small_face_path: Path
) -> None:
    """The layout of ``conformorph serve``: jobs, validations and webhooks on workers of their
    own. A receiver answering one byte every 3 s (issue 30: one attempt held for 201 s, and
    other uploads got 503) is cut at ``CONFORMORPH_CALLBACK_TIMEOUT`` seconds in all, while
    uploads go on being validated."""
    env = _env(
        tmp_path,
        **HOOKS,
        CONFORMORPH_CALLBACK_TIMEOUT="3",
        CONFORMORPH_CALLBACK_MAX_ATTEMPTS="2",
    )
    start_worker(env, queues="jobs", log=tmp_path / "jobs.log")
    start_worker(env, queues="interactive", log=tmp_path / "interactive.log")
    start_worker(env, queues="webhooks", log=tmp_path / "webhooks.log")
    svc = Service(tmp_path, env)
    svc.ready()
    mesh = svc.upload(small_face_path)
    with webhook_receiver([200, 200], trickle=3.0) as rx:
        job_id = svc.submit("/v1/conformal-maps", {"mesh": mesh, "callback_url": rx.url})
        rx.wait_for(1, timeout=120)  # the first attempt is being held by the receiver
        faces = small_face_path.read_bytes()
        for k in range(3):  # new bytes each time: each one validated by a worker
            t0 = time.monotonic()
            r = svc.client.post(
                "/v1/meshes", files={"file": ("f.obj", faces + f"# {k}\n".encode())}
            )
            assert r.status_code == 201, r.text
            assert time.monotonic() - t0 < 10.0
        deadline = time.monotonic() + 60
        while not (cb := svc.client.get(f"/v1/jobs/{job_id}").json()["callback"])["attempts"]:
            assert time.monotonic() < deadline, cb
            time.sleep(0.2)
    first = cb["attempts"][0]
    assert first["outcome"] == "retry" and "deadline" in first["error"], first
    assert first["seconds"] < 4.0, first
