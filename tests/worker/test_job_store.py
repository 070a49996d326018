"""The job store on SQLite and on PostgreSQL: jobs, leases, requeue, keys, isolation."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from conformorph.worker import names
from conformorph.worker.job_store import (
    KEY_PREFIX,
    JobStore,
    MeshView,
    TooManyActiveJobs,
    hash_api_key,
)


@pytest.fixture(params=["sqlite", "postgresql"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[JobStore]:
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path / 'jobs.sqlite'}"
    else:
        url = request.getfixturevalue("pg_url")
    s = JobStore(url)
    yield s
    s.dispose()


def _job(
    store: JobStore, owner: str = "a", kind: str = names.KIND_RECONSTRUCTION, **kw: object
) -> str:
    job, created = store.create_job(owner=owner, kind=kind, params={"mesh": {"id": "m"}}, **kw)  # type: ignore[arg-type]
    assert created
    return job.id


def test_create_get_list_and_owner_isolation(store: JobStore) -> None:
    ids = [_job(store) for _ in range(3)]
    other = _job(store, owner="b")
    job = store.get_job(ids[0], "a")
    assert (
        job is not None
        and job.state == "queued"
        and job.stages == names.KIND_STAGES["reconstruction"]
    )
    assert store.get_job(ids[0], "b") is None and store.get_job(other, "a") is None
    page, total = store.list_jobs("a", limit=2)
    assert total == 3 and [j.id for j in page] == ids[::-1][:2]
    assert store.count_active("a") == 3 and store.count_active("b") == 1


def test_idempotency_key_returns_the_same_job(store: JobStore) -> None:
    a, created_a = store.create_job(
        owner="a", kind="conformal_map", params={}, idempotency_key="k1"
    )
    b, created_b = store.create_job(
        owner="a", kind="conformal_map", params={}, idempotency_key="k1"
    )
    c, created_c = store.create_job(
        owner="b", kind="conformal_map", params={}, idempotency_key="k1"
    )
    assert created_a and not created_b and created_c
    assert a.id == b.id != c.id


def test_failing_a_job_can_release_its_idempotency_key(store: JobStore) -> None:
    kw = {"owner": "a", "kind": "conformal_map", "params": {}, "idempotency_key": "k"}
    kept, _ = store.create_job(**kw)  # type: ignore[arg-type]
    store.fail_job(kept.id, {"type": "x", "message": "m", "field": None})
    assert store.create_job(**kw)[0].id == kept.id  # type: ignore[arg-type]  # still held
    store.delete_job(kept.id, "a")
    first, _ = store.create_job(**kw)  # type: ignore[arg-type]
    store.fail_job(
        first.id,
        {"type": "broker_unavailable", "message": "m", "field": None},
        release_idempotency_key=True,
    )
    second, created = store.create_job(**kw)  # type: ignore[arg-type]
    assert created and second.id != first.id
    failed = store.get_job(first.id, "a")
    assert failed is not None and failed.state == names.FAILED and failed.idempotency_key is None
    assert store.job_by_idempotency_key("a", "k") == store.get_job(second.id)


def test_concurrent_submissions_never_pass_the_active_job_limit(store: JobStore) -> None:
    # issue 15: 45-60 concurrent submissions against a limit of 32 admitted 37 when
    # the count and the insert were two steps
    limit, n = 32, 60
    created: list[str] = []
    refused: list[TooManyActiveJobs] = []
    barrier = threading.Barrier(n)

    def submit() -> None:
        barrier.wait()
        try:
            job, _ = store.create_job(owner="a", kind="conformal_map", params={}, max_active=limit)
            created.append(job.id)
        except TooManyActiveJobs as exc:
            refused.append(exc)

    threads = [threading.Thread(target=submit) for _ in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert (len(created), len(refused), len(set(created))) == (limit, n - limit, limit)
    assert store.count_active("a") == limit
    assert {(e.active, e.limit) for e in refused} == {(limit, limit)}


def test_active_job_limit_counts_only_the_owners_active_jobs(store: JobStore) -> None:
    kw = {"max_active": 2}
    first = _job(store, **kw)
    _job(store, idempotency_key="k", **kw)
    with pytest.raises(
        TooManyActiveJobs, match="this key has 2 queued or running jobs; the limit is 2"
    ):
        _job(store, **kw)
    # a key already used names its job, limit or not; another owner has its own count
    again, created = store.create_job(
        owner="a", kind=names.KIND_RECONSTRUCTION, params={}, idempotency_key="k", max_active=2
    )
    assert not created and again == store.job_by_idempotency_key("a", "k")
    _job(store, owner="b", **kw)
    store.cancel_job(first, "a")  # an ended job no longer counts
    _job(store, **kw)
    with pytest.raises(TooManyActiveJobs):
        _job(store, **kw)
    assert store.count_active("a") == 2 and store.list_jobs("a")[1] == 3


def test_stage_lease_claim_renew_expire_complete(store: JobStore) -> None:
    jid = _job(store)
    c1 = store.claim_stage(jid, "conformal_map", "w1", 0.3, "t1")
    assert c1.status == "claimed" and c1.job is not None and c1.job.state == "running"
    busy = store.claim_stage(jid, "conformal_map", "w2", 0.3, "t2")
    assert busy.status == "busy" and 0 < busy.wait <= 0.3
    assert store.renew_lease(jid, "w1", 0.3) and not store.renew_lease(jid, "w2", 0.3)
    time.sleep(0.4)  # w1 "dies": its lease runs out
    assert store.expired_jobs() == [jid]
    c2 = store.claim_stage(jid, "conformal_map", "w2", 30, "t2")
    assert c2.status == "claimed" and c2.job is not None and c2.job.attempts == 2
    assert not store.renew_lease(jid, "w1", 30)
    after = store.complete_stage(
        jid,
        "conformal_map",
        "w2",
        seconds=1.5,
        artifacts={"a.npz": {"key": "k"}},
        handoff_lease_seconds=60,
    )
    assert after is not None and after.state == "running" and after.stages_done == ["conformal_map"]
    assert after.progress == pytest.approx(1 / 3) and after.stage_seconds == {"conformal_map": 1.5}
    assert store.claim_stage(jid, "conformal_map", "w3", 30, None).status == "done"
    for st in ("curvature", "reconstruct"):
        assert store.claim_stage(jid, st, "w3", 30, None).status == "claimed"
        store.complete_stage(jid, st, "w3", seconds=0.1, artifacts={}, handoff_lease_seconds=60)
    job = store.get_job(jid)
    assert job is not None and job.state == "succeeded" and job.progress == 1.0 and job.finished_at
    assert set(job.artifacts) == {"a.npz"} and job.lease_until is None
    assert store.claim_stage(jid, "reconstruct", "w4", 30, None).status == "gone"
    assert store.expired_jobs() == []


def test_take_expired_has_exactly_one_winner(store: JobStore) -> None:
    jid = _job(store, queued_lease_seconds=0.0)
    time.sleep(0.01)
    wins: list[object] = []
    barrier = threading.Barrier(4)

    def take() -> None:
        barrier.wait()
        wins.append(store.take_expired(jid, grace_seconds=60))

    threads = [threading.Thread(target=take) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sum(w is not None for w in wins) == 1
    job = store.get_job(jid)
    assert job is not None and job.requeues == 1 and store.expired_jobs() == []


def test_concurrent_claims_have_exactly_one_winner(store: JobStore) -> None:
    jid = _job(store)
    results: list[str] = []
    barrier = threading.Barrier(4)

    def claim(i: int) -> None:
        barrier.wait()
        results.append(store.claim_stage(jid, "conformal_map", f"w{i}", 30, None).status)

    threads = [threading.Thread(target=claim, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(results) == ["busy", "busy", "busy", "claimed"]


def test_fail_and_cancel_are_final(store: JobStore) -> None:
    jid = _job(store)
    store.claim_stage(jid, "conformal_map", "w", 30, None)
    store.fail_job(
        jid, {"type": "folded_map", "message": "m", "field": None, "stage": "conformal_map"}
    )
    job = store.get_job(jid)
    assert job is not None and job.state == "failed" and job.error is not None
    assert job.error["type"] == "folded_map"
    assert store.cancel_job(jid, "a").state == "failed"  # type: ignore[union-attr]
    jid2 = _job(store)
    assert store.cancel_job(jid2, "b") is None  # someone else's job: untouched
    assert store.cancel_job(jid2, "a").state == "cancelled"  # type: ignore[union-attr]
    assert store.claim_stage(jid2, "conformal_map", "w", 30, None).status == "gone"
    store.fail_job(jid2, {"type": "x", "message": "m"})
    assert store.get_job(jid2).state == "cancelled"  # type: ignore[union-attr]
    assert not store.delete_job(jid2, "b") and store.delete_job(jid2, "a")
    assert store.get_job(jid2) is None


def test_keys_are_stored_hashed(store: JobStore) -> None:
    assert store.count_keys() == 0
    kid, plain = store.create_key("alice")
    assert plain.startswith(KEY_PREFIX) and len(plain) > 40
    assert store.key_id_for(plain) == kid and store.key_id_for(plain + "x") is None
    from sqlalchemy import select

    from conformorph.worker.job_store import ApiKey

    with store.session() as s:
        rows = list(s.scalars(select(ApiKey)))
    assert [r.key_hash for r in rows] == [hash_api_key(plain)] and plain not in rows[0].key_hash
    with pytest.raises(ValueError, match="1-200"):
        store.create_key("")


def test_meshes_are_per_owner(store: JobStore) -> None:
    v = MeshView("a", "m1", "f.obj", "obj", "meshes/a/m1.obj", 10, {"n_vertices": 3}, 1.0)
    assert store.add_mesh(v) == v
    assert store.add_mesh(v) == v  # same id again: the existing record
    assert store.get_mesh("b", "m1") is None
    assert [m.id for m in store.list_meshes("a")] == ["m1"]


def test_a_key_artifact_stored_by_two_processes_at_once_keeps_one_row(
    store: JobStore, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The upload's precompute and a job may both store one artifact: the writer whose
    read came before the other's commit inserts too, and updates the row instead of
    failing the job on the unique key (seen as a failed batch job before)."""
    from sqlalchemy.orm import Session

    store.add_key_artifact("a", "m", "keys/a/m/k.npz", 10)
    real_get = Session.get
    calls = []

    def stale_get(self: Session, *args: object, **kw: object) -> object:
        calls.append(args)
        return None  # the other process's row is not yet visible to this read

    monkeypatch.setattr(Session, "get", stale_get)
    store.add_key_artifact("a", "m", "keys/a/m/k.npz", 12)
    monkeypatch.setattr(Session, "get", real_get)
    assert calls and store.key_artifacts_of("a", "m") == [("keys/a/m/k.npz", 12)]
