"""worker/retention.py: expired jobs and unused uploads go, nothing live does; the
per-key storage quota (413)."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import pytest

from conformorph.worker.job_store import InputGone
from conformorph.worker.retention import run_cleanup
from tests.service.conftest import Api

DAY = 86400.0


def _mesh(api: Api, path: Path) -> dict[str, Any]:
    r = api.upload(path)
    assert r.status_code in (200, 201), r.text
    m = api.store.get_mesh("open", r.json()["id"])
    assert m is not None
    return {"id": m.id, "storage_key": m.storage_key, "file_type": m.file_type}


def _cleanup(api: Api, now: float, jobs: float = 7 * DAY, uploads: float = 7 * DAY) -> Any:
    return run_cleanup(
        api.store,
        api.storage,
        job_retention_seconds=jobs,
        upload_retention_seconds=uploads,
        now=now,
    )


def test_expired_jobs_and_unused_uploads_go_live_ones_stay(api: Api, small_face_path: Path) -> None:
    mesh = _mesh(api, small_face_path)
    size = api.storage.size(mesh["storage_key"])
    done = api.client.post("/v1/conformal-maps", json={"mesh": mesh["id"]}).json()["id"]
    api.run_job(done)
    live = api.client.post("/v1/conformal-maps", json={"mesh": mesh["id"]}).json()["id"]
    finished = api.store.get_job(done)
    assert finished is not None and finished.state == "succeeded"
    artifact_bytes = sum(int(r["size"]) for r in finished.artifacts.values())
    assert artifact_bytes > 0 and list(api.storage.iter_keys(f"jobs/{done}"))  # type: ignore[attr-defined]

    # within the retention: nothing goes
    report = _cleanup(api, time.time() + DAY)
    assert (report.jobs, report.uploads, report.bytes) == (0, 0, 0)
    # past it: the finished job and its artifacts go; the queued job and the mesh it
    # uses stay, however old
    report = _cleanup(api, time.time() + 8 * DAY)
    assert (report.jobs, report.uploads, report.bytes) == (1, 0, artifact_bytes)
    assert api.store.get_job(done) is None
    assert list(api.storage.iter_keys(f"jobs/{done}")) == []  # type: ignore[attr-defined]
    assert api.client.get(f"/v1/jobs/{done}").status_code == 404
    assert api.store.get_job(live) is not None and api.storage.exists(mesh["storage_key"])
    # the live job ends; at a "now" 8 days on, the job that last used the mesh was
    # created more than 7 days before, and no live job uses it: the mesh goes
    api.run_job(live)
    report = _cleanup(api, time.time() + 8 * DAY, jobs=0)
    assert (report.jobs, report.uploads, report.bytes) == (0, 1, size)
    assert api.store.get_mesh("open", mesh["id"]) is None
    assert not api.storage.exists(mesh["storage_key"])
    # the job kept by jobs=0 goes now; then a second pass frees nothing
    again = _cleanup(api, time.time() + 8 * DAY)
    assert (again.jobs, again.uploads) == (1, 0) and again.bytes > 0
    nothing = _cleanup(api, time.time() + 8 * DAY)
    assert (nothing.jobs, nothing.uploads, nothing.bytes) == (0, 0, 0)
    totals = api.store.cleanup_totals()
    assert totals["jobs"] == 2 and totals["uploads"] == 1
    assert totals["bytes"] == artifact_bytes + size + again.bytes


def test_recently_used_upload_is_kept(api: Api, small_face_path: Path) -> None:
    mesh = _mesh(api, small_face_path)
    created = time.time()
    job = api.client.post("/v1/conformal-maps", json={"mesh": mesh["id"]}).json()["id"]
    api.run_job(job)
    # the upload is 8 days old at "now", but the job that used it is 3 days old
    now = created + 3 * DAY
    api.store._update_job(job, created_at=created)  # noqa: SLF001 - age the rows by hand
    report = run_cleanup(
        api.store,
        api.storage,
        job_retention_seconds=0,
        upload_retention_seconds=2 * DAY,
        now=now,
    )
    assert report.uploads == 1  # used 3 days ago > 2 days: goes
    mesh2 = _mesh(api, small_face_path)
    job2 = api.client.post("/v1/conformal-maps", json={"mesh": mesh2["id"]}).json()["id"]
    api.run_job(job2)
    report = run_cleanup(
        api.store,
        api.storage,
        job_retention_seconds=0,
        upload_retention_seconds=4 * DAY,
        now=time.time() + 3 * DAY,
    )
    assert report.uploads == 0 and api.storage.exists(mesh2["storage_key"])


def test_zero_retention_keeps_everything(api: Api, small_face_path: Path) -> None:
    mesh = _mesh(api, small_face_path)
    job = api.client.post("/v1/conformal-maps", json={"mesh": mesh["id"]}).json()["id"]
    api.run_job(job)
    report = _cleanup(api, time.time() + 1000 * DAY, jobs=0, uploads=0)
    assert (report.jobs, report.uploads, report.bytes) == (0, 0, 0)
    assert api.store.get_job(job) is not None


def test_job_on_a_deleted_upload_is_refused(api: Api, small_face_path: Path) -> None:
    mesh = _mesh(api, small_face_path)
    assert _cleanup(api, time.time() + 8 * DAY).uploads == 1
    with pytest.raises(InputGone, match=mesh["id"]):
        api.store.create_job(owner="open", kind="conformal_map", params={"mesh": mesh})
    # over HTTP the route itself no longer finds it: 404 input_expired, as the README
    # promises (issue 30 item 11: it was not_found), naming the field
    r = api.client.post("/v1/conformal-maps", json={"mesh": mesh["id"]})
    assert r.status_code == 404 and r.json()["error"]["type"] == "input_expired", r.text
    assert r.json()["error"]["field"] == "mesh" and "upload it again" in r.text
    body = {"meshes": [mesh["id"], mesh["id"]], "landmarks": [[0, 1, 2], [0, 1, 2]]}
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 404 and r.json()["error"]["type"] == "input_expired", r.text
    # an id never uploaded is still not_found
    r = api.client.post("/v1/conformal-maps", json={"mesh": "0" * 32})
    assert r.status_code == 404 and r.json()["error"]["type"] == "not_found"
    # uploaded again (the same id): jobs on it run again
    assert _mesh(api, small_face_path)["id"] == mesh["id"]
    assert api.client.post("/v1/conformal-maps", json={"mesh": mesh["id"]}).status_code == 202


def test_cleanup_concurrent_with_job_creation_loses_nothing_live(
    api: Api, small_face_path: Path
) -> None:
    """Jobs are created (by the store call the route makes, on an input looked up
    before) while cleanups delete every old unused upload: each creation either
    fails with InputGone or its job's input still exists afterwards."""
    mesh = _mesh(api, small_face_path)
    created: list[str] = []
    refused: list[int] = []
    stop = threading.Event()
    started = threading.Event()  # the cleaners start once the first creation is done

    def create() -> None:
        while not stop.is_set():
            try:
                job, _ = api.store.create_job(
                    owner="open", kind="conformal_map", params={"mesh": mesh}
                )
                created.append(job.id)
            except InputGone:
                refused.append(1)
                return
            finally:
                started.set()

    def clean() -> None:
        started.wait(timeout=30)  # a loaded machine may schedule a cleaner first
        for _ in range(20):
            # a cutoff before every job: only "no live job uses it" protects the mesh
            run_cleanup(
                api.store,
                api.storage,
                job_retention_seconds=0,
                upload_retention_seconds=1.0,
                now=time.time() + 10 * DAY,
            )

    maker = threading.Thread(target=create)
    cleaners = [threading.Thread(target=clean) for _ in range(2)]
    maker.start()
    for t in cleaners:
        t.start()
    for t in cleaners:
        t.join()
    stop.set()
    maker.join()
    assert created  # at least the first creation raced nothing
    if api.store.get_mesh("open", mesh["id"]) is not None:
        assert api.storage.exists(mesh["storage_key"])
    else:
        # deleted: only possible before any job existed, which the creator saw
        assert refused and not created
    for job_id in created:
        job = api.store.get_job(job_id)
        assert job is not None and job.state == "queued"
    assert api.storage.exists(mesh["storage_key"])


def test_storage_quota_answers_413(make_api: Any, small_face_path: Path, tmp_path: Path) -> None:
    size = small_face_path.stat().st_size
    api = make_api(storage_quota_bytes=size + 10)
    assert api.upload(small_face_path).status_code == 201
    # the same bytes again are no new storage: 200
    assert api.upload(small_face_path).status_code == 200
    other = tmp_path / "other.obj"
    other.write_bytes(small_face_path.read_bytes() + b"\n# another file\n")
    r = api.upload(other)
    assert r.status_code == 413, r.text
    err = r.json()["error"]
    assert err["type"] == "storage_quota_exceeded" and err["field"] == "file"
    assert str(size) in err["message"] and str(size + 10) in err["message"]
    assert api.store.storage_used("open") == size
    # no quota
    free = make_api(storage_quota_bytes=0)
    assert free.upload(small_face_path).status_code == 201
    assert free.upload(other).status_code == 201


def test_storage_used_counts_artifacts(api: Api, small_face_path: Path) -> None:
    mesh = _mesh(api, small_face_path)
    size = small_face_path.stat().st_size
    assert api.store.storage_used("open") == size
    job = api.client.post("/v1/conformal-maps", json={"mesh": mesh["id"]}).json()["id"]
    api.run_job(job)
    view = api.store.get_job(job)
    assert view is not None
    art = sum(int(r["size"]) for r in view.artifacts.values())
    assert api.store.storage_used("open") == size + art
    assert api.store.storage_used("someone-else") == 0


def test_cleanup_totals_are_scraped(api: Api, small_face_path: Path) -> None:
    from prometheus_client.parser import text_string_to_metric_families

    mesh = _mesh(api, small_face_path)
    size = small_face_path.stat().st_size
    assert _cleanup(api, time.time() + 8 * DAY).uploads == 1
    assert api.store.get_mesh("open", mesh["id"]) is None
    r = api.client.get("/metrics")
    samples = {
        s.labels["what"]: s.value
        for f in text_string_to_metric_families(r.text)
        if f.name == "conformorph_cleanup_freed"
        for s in f.samples
        if s.name == "conformorph_cleanup_freed_total"
    }
    assert samples == {"jobs": 0.0, "uploads": 1.0, "bytes": float(size)}
