"""Issue 30, item 9: with the object store down, the API answers 503 with Retry-After
(never 500), DELETE of a job removes its artifacts before its record (so nothing is
orphaned), and a stage that cannot reach the store is retried, not failed.

The store is moto's real S3 server (tests/s3_server.py); "down" is an S3 storage of the
same bucket whose endpoint is a loopback port nobody listens on, as the API sees it when
the store's host is gone.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from conformorph.pipelines.mesh_io import write_obj
from conformorph.service.core.config import Settings
from conformorph.service.main import create_app
from conformorph.worker.job_runner import Runtime, TransientStageError, run_stage
from conformorph.worker.job_store import JobStore
from conformorph.worker.s3_storage import S3Options, S3Storage
from conformorph.worker.storage import StorageUnavailable
from tests.fixtures.make_service_small_face import small_face
from tests.live_server import free_port
from tests.s3_server import AWS_TEST_ENV, S3Endpoint
from tests.service.conftest import InlineTaskClient, run_job_inline


@pytest.fixture
def aws_env(monkeypatch: pytest.MonkeyPatch) -> None:
    for k in ("AWS_ENDPOINT_URL", "AWS_PROFILE", "AWS_SESSION_TOKEN"):
        monkeypatch.delenv(k, raising=False)
    for k, v in AWS_TEST_ENV.items():
        monkeypatch.setenv(k, v)


class Side:
    """One API over a job store and an S3 storage (up or down)."""

    def __init__(self, settings: Settings, store: JobStore, storage: S3Storage) -> None:
        self.storage = storage
        self.app = create_app(
            settings, store=store, storage=storage, task_client=InlineTaskClient(storage)
        )
        self.client = TestClient(self.app, raise_server_exceptions=False)
        self.runtime = Runtime(settings, store, storage, worker_id="test-worker")


@pytest.fixture
def sides(moto_s3: S3Endpoint, tmp_path: Path, aws_env: None) -> Iterator[tuple[Side, Side]]:
    bucket = moto_s3.new_bucket()
    settings = Settings(data_dir=tmp_path / "data", open_mode_recheck_seconds=0.0)
    store = JobStore(settings.resolved_database_url)

    def s3(url: str, cache: str) -> S3Storage:
        opts: dict[str, Any] = {"endpoint_url": url, "addressing_style": "path"}
        return S3Storage(S3Options(bucket=bucket, prefix="a", cache_dir=tmp_path / cache, **opts))

    up = Side(settings, store, s3(moto_s3.url, "c-up"))
    down = Side(settings, store, s3(f"http://127.0.0.1:{free_port()}", "c-down"))
    yield up, down
    for side in (up, down):
        side.client.close()
    store.dispose()


def _finished_job(up: Side, tmp_path: Path) -> str:
    V, F = small_face(6)
    path = tmp_path / "face.obj"
    write_obj(path, V, F)
    r = up.client.post("/v1/meshes", files={"file": ("face.obj", path.read_bytes())})
    assert r.status_code == 201, r.text
    r = up.client.post("/v1/conformal-maps", json={"mesh": r.json()["id"]})
    assert r.status_code == 202, r.text
    jid = str(r.json()["id"])
    assert [o.status for o in run_job_inline(up.runtime, jid)] == ["ran"]
    return jid


def test_store_down_is_503_with_retry_after_and_delete_orphans_nothing(
    sides: tuple[Side, Side], tmp_path: Path, moto_s3: S3Endpoint
) -> None:
    up, down = sides
    jid = _finished_job(up, tmp_path)
    url = f"/v1/jobs/{jid}/artifacts/disk_map.npz"
    assert up.client.get(url).status_code == 200
    for method in ("GET", "HEAD"):
        r = down.client.request(method, url)
        assert r.status_code == 503, (method, r.status_code, r.text)
        assert int(r.headers["Retry-After"]) > 0
        if method == "GET":
            assert r.json()["error"]["type"] == "storage_unavailable"
    r = down.client.get(url, headers={"Range": "bytes=0-9"})
    assert r.status_code == 503
    r = down.client.post(
        "/v1/meshes", files={"file": ("f.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")}
    )
    assert r.status_code == 503 and "Retry-After" in r.headers, r.text
    # DELETE during the outage: 503, and the job (with its artifacts) is still there
    r = down.client.delete(f"/v1/jobs/{jid}")
    assert r.status_code == 503 and "Retry-After" in r.headers, r.text
    assert up.client.get(f"/v1/jobs/{jid}").status_code == 200
    keys = [
        o["Key"]
        for o in moto_s3.client()
        .list_objects_v2(Bucket=up.storage.options.bucket, Prefix=f"a/jobs/{jid}/")
        .get("Contents", [])
    ]
    assert keys, "the artifacts are still stored"
    # once the store is back, DELETE removes both: nothing orphaned
    assert up.client.delete(f"/v1/jobs/{jid}").status_code == 204
    assert up.client.get(f"/v1/jobs/{jid}").status_code == 404
    listing = moto_s3.client().list_objects_v2(
        Bucket=up.storage.options.bucket, Prefix=f"a/jobs/{jid}/"
    )
    assert listing.get("KeyCount", 0) == 0


def test_a_stage_that_cannot_reach_the_store_is_retried_not_failed(
    sides: tuple[Side, Side], tmp_path: Path
) -> None:
    up, down = sides
    V, F = small_face(6)
    path = tmp_path / "face.obj"
    write_obj(path, V, F)
    r = up.client.post("/v1/meshes", files={"file": ("face.obj", path.read_bytes())})
    r = up.client.post("/v1/conformal-maps", json={"mesh": r.json()["id"]})
    jid = str(r.json()["id"])
    stage = r.json()["stages"][0]["name"]
    from conformorph.worker import stages

    # the job submitted during the outage: its stage raises a transient error (Celery
    # retries it with back-off), the job is not failed
    with pytest.raises(TransientStageError) as info:
        run_stage(down.runtime, jid, stage, stages.ALL_STAGE_BODIES[stage], task_id="t1")
    assert isinstance(info.value.__cause__, StorageUnavailable)
    assert down.runtime.store.get_job(jid).state == "running"
    # the lease is handed back, so the retry runs on whichever worker process gets it
    assert down.runtime.store.hand_back_lease(jid, "test-worker", 60.0)
    up.runtime.worker_id = "another-process"
    assert [o.status for o in run_job_inline(up.runtime, jid)] == ["ran"]
    assert up.client.get(f"/v1/jobs/{jid}").json()["state"] == "succeeded"
    # the handed-back claim is not counted as a worker lost (requeue's max_attempts)
    row = up.runtime.store.get_job(jid)
    assert row is not None and row.attempts == len(row.stages)


def test_retry_plan_lets_an_outage_outlast_celerys_default_limit() -> None:
    """Celery's retry(max_retries=None) means the task's default (3): an outage's 4th
    retry raised instead, and the job came back only by its lease requeue."""
    from conformorph.worker.tasks import (
        STAGE_TASK_OBJECTS,
        STORAGE_OUTAGE_RETRIES,
        retry_plan,
    )

    task_max = next(iter(STAGE_TASK_OBJECTS.values())).max_retries
    outage = TransientStageError("x")
    outage.__cause__ = StorageUnavailable("the store is down")
    other = TransientStageError("y")
    other.__cause__ = OSError("disk hiccup")
    waits = []
    for n in range(STORAGE_OUTAGE_RETRIES):
        plan = retry_plan(n, outage, task_max)
        assert plan is not None
        waits.append(plan[0])
        assert plan[1] is not None and plan[1] > n  # Celery lets this retry through
    assert waits[:7] == [1, 2, 4, 8, 16, 32, 60] and max(waits) == 60
    assert 300 <= sum(waits) <= 600  # about 7 minutes of outage
    assert retry_plan(STORAGE_OUTAGE_RETRIES, outage, task_max) is None
    assert [retry_plan(n, other, task_max) for n in range(4)] == [
        (1.0, None),
        (2.0, None),
        (4.0, None),
        None,
    ]
