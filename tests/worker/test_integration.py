"""End to end with real worker processes: the embedded broker, real Redis and RabbitMQ.

Each test starts ``conformorph worker`` processes, talks to the API in this
process through the real Celery client, and runs whole jobs through the real
pipeline on the small face fixture. Also: a worker SIGKILLed mid-stage does
not lose its job (embedded: the job store's lease and requeue; Redis and
RabbitMQ: redelivery), and cancelling a running job stops it. RabbitMQ is the
one at ``CONFORMORPH_TEST_AMQP`` (default ``amqp://guest:guest@127.0.0.1:5672//``);
its tests skip when it does not answer.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from conformorph.pipelines.mesh_io import read_mesh, write_obj
from conformorph.service.core.config import Settings
from conformorph.service.main import create_app
from conformorph.worker import names
from conformorph.worker.config import WorkerSettings
from conformorph.worker.job_store import JobStore, JobView
from tests.conftest import ROOT, WorkerProcess
from tests.fixtures.make_service_small_face import small_face

pytestmark = pytest.mark.timeout(400)

AMQP_TEST_URL = os.environ.get("CONFORMORPH_TEST_AMQP", "amqp://guest:guest@127.0.0.1:5672//")

FAST = {
    "CONFORMORPH_LEASE_SECONDS": "2",
    "CONFORMORPH_REQUEUE_CHECK_SECONDS": "0.3",
    "CONFORMORPH_EMBEDDED_POLLING_INTERVAL": "0.05",
}


def _env(data_dir: Path, **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
    env.update(FAST)
    env.update(extra)
    env["CONFORMORPH_DATA_DIR"] = str(data_dir)
    env["PYTHONPATH"] = str(ROOT)
    return env


class Service:
    def __init__(self, data_dir: Path, env: dict[str, str]) -> None:
        overrides = {
            k.removeprefix("CONFORMORPH_").lower(): v
            for k, v in env.items()
            if k.startswith("CONFORMORPH_")
        }
        self.settings = Settings(**overrides)  # type: ignore[arg-type]
        self.store = JobStore(self.settings.resolved_database_url)
        self.client = TestClient(create_app(self.settings, store=self.store))

    def upload(self, path: Path) -> str:
        with open(path, "rb") as f:
            r = self.client.post("/v1/meshes", files={"file": (path.name, f.read())})
        assert r.status_code in (200, 201), r.text
        return str(r.json()["id"])

    def submit(self, route: str, body: dict[str, Any]) -> str:
        r = self.client.post(route, json=body)
        assert r.status_code == 202, r.text
        return str(r.json()["id"])

    def wait(
        self,
        job_id: str,
        until: Callable[[JobView], bool],
        timeout: float = 120.0,
        poll: float = 0.05,
    ) -> JobView:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            job = self.store.get_job(job_id)
            if job is not None and until(job):
                return job
            time.sleep(poll)
        raise AssertionError(
            f"job {job_id} did not get there in {timeout} s: {self.store.get_job(job_id)}"
        )

    def ready(self, timeout: float = 60.0) -> dict[str, Any]:
        """``/readyz`` once it says ready: a worker just started takes a few seconds
        (more on a loaded machine) before it consumes the validation queue."""
        deadline = time.monotonic() + timeout
        while (r := self.client.get("/readyz").json())["status"] != "ready":
            assert time.monotonic() < deadline, r
            time.sleep(0.5)
        return r  # type: ignore[no-any-return]

    def finished(self, job_id: str, timeout: float = 120.0) -> dict[str, Any]:
        self.wait(job_id, lambda j: j.state in ("succeeded", "failed", "cancelled"), timeout)
        return self.client.get(f"/v1/jobs/{job_id}").json()  # type: ignore[no-any-return]


@pytest.fixture
def big_face(tmp_path: Path) -> Path:
    """A 19k-vertex version of the face: its scalar-H reconstruction takes seconds."""
    V, F = small_face(rings=80)
    p = tmp_path / "big_face.obj"
    write_obj(p, V, F)
    return p


@pytest.fixture
def amqp_url() -> str:
    """The test RabbitMQ, conformorph's queues emptied first (a worker SIGKILLed by an
    earlier run can leave messages behind); skips when RabbitMQ does not answer."""
    from kombu import Connection

    try:
        with Connection(AMQP_TEST_URL, connect_timeout=2.0) as conn:
            conn.ensure_connection(max_retries=1, timeout=2.0)
            channel = conn.default_channel
            for queue in (names.QUEUE_JOBS, names.QUEUE_INTERACTIVE):
                channel.queue_declare(queue=queue, durable=True, auto_delete=False)
                channel.queue_purge(queue)
    except Exception as exc:  # noqa: BLE001 - any failure to reach it: no RabbitMQ here
        pytest.skip(
            f"RabbitMQ does not answer at {AMQP_TEST_URL} ({exc!r}); set "
            "CONFORMORPH_TEST_AMQP or start rabbitmq-server"
        )
    return AMQP_TEST_URL


def _whole_jobs(svc: Service, small_face_path: Path) -> None:
    mid = svc.upload(small_face_path)
    rec = svc.submit("/v1/reconstructions", {"mesh": mid})
    cmap = svc.submit("/v1/conformal-maps", {"mesh": mid, "method": "qiem"})
    # follow the reconstruction through the event stream until it ends
    with svc.client.stream("GET", f"/v1/jobs/{rec}/events") as r:
        text = "".join(r.iter_text())
    states = [
        json.loads(b.split("data: ", 1)[1])
        for b in text.split("\n\n")
        if b.startswith("event: state")
    ]
    assert states[-1]["state"] == "succeeded", states[-1]
    assert all(a["progress"] <= b["progress"] for a, b in zip(states, states[1:], strict=False))
    job = svc.finished(rec)
    assert [s["state"] for s in job["stages"]] == ["done", "done", "done"]
    obj = svc.client.get(f"/v1/jobs/{rec}/artifacts/reconstruction.obj")
    X, _ = read_mesh(obj.content, "obj")
    V, _ = read_mesh(small_face_path)
    assert X.shape == V.shape
    assert (
        svc.client.get(f"/v1/jobs/{rec}/artifacts/errors.json").json()["relative_error"]["L2"]
        < 5e-3
    )
    job = svc.finished(cmap)
    assert job["state"] == "succeeded", job
    q = svc.client.get(f"/v1/jobs/{cmap}/artifacts/quality.json").json()
    assert q["method"] == "qiem" and q["flipped"] == 0


def _scraped_metrics(svc: Service) -> dict[str, dict[tuple[tuple[str, str], ...], float]]:
    from prometheus_client.parser import text_string_to_metric_families

    r = svc.client.get("/metrics")
    assert r.status_code == 200, r.text
    out: dict[str, dict[tuple[tuple[str, str], ...], float]] = {}
    for family in text_string_to_metric_families(r.text):
        for sample in family.samples:
            out.setdefault(sample.name, {})[tuple(sorted(sample.labels.items()))] = sample.value
    return out


def _assert_broker_metrics(svc: Service) -> None:
    """After :func:`_whole_jobs`: the jobs are counted and every queue is empty."""
    m = _scraped_metrics(svc)
    jobs = m["conformorph_jobs"]
    assert jobs[(("kind", "reconstruction"), ("state", "succeeded"))] == 1
    assert jobs[(("kind", "conformal_map"), ("state", "succeeded"))] == 1
    depth = m["conformorph_queue_depth"]
    assert depth == {
        (("queue", names.QUEUE_INTERACTIVE),): 0,
        (("queue", names.QUEUE_JOBS),): 0,
        (("queue", names.QUEUE_WEBHOOKS),): 0,
    }
    stage = m["conformorph_stage_duration_seconds_count"]
    assert stage[(("kind", "reconstruction"), ("stage", "reconstruct"))] == 1


def test_embedded_broker_runs_whole_jobs(
    tmp_path: Path, start_worker: Any, small_face_path: Path
) -> None:
    env = _env(tmp_path)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    assert svc.client.get("/readyz").json()["embedded"] is True
    _whole_jobs(svc, small_face_path)


@pytest.mark.redis
def test_redis_broker_runs_whole_jobs(
    tmp_path: Path, start_worker: Any, small_face_path: Path, redis_url: str
) -> None:
    env = _env(tmp_path, CONFORMORPH_BROKER_URL=redis_url)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    r = svc.ready()
    assert r["embedded"] is False and r["checks"]["broker"] is True
    _whole_jobs(svc, small_face_path)
    _assert_broker_metrics(svc)


@pytest.mark.rabbitmq
def test_rabbitmq_broker_runs_whole_jobs(
    tmp_path: Path, start_worker: Any, small_face_path: Path, amqp_url: str
) -> None:
    env = _env(tmp_path, CONFORMORPH_BROKER_URL=amqp_url)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    r = svc.ready()
    assert r["embedded"] is False and r["checks"]["broker"] is True
    assert svc.settings.resolved_result_backend.startswith("db+sqlite:///")
    _whole_jobs(svc, small_face_path)
    _assert_broker_metrics(svc)


def _kill_mid_reconstruct(svc: Service, worker: WorkerProcess, big_face: Path) -> str:
    mid = svc.upload(big_face)
    jid = svc.submit("/v1/reconstructions", {"mesh": mid, "curvature": "scalar"})
    svc.wait(jid, lambda j: j.state == "running" and j.stage == "reconstruct", timeout=180)
    time.sleep(0.3)
    before = svc.store.get_job(jid)
    assert (
        before is not None and before.state == "running" and "reconstruct" not in before.stages_done
    )
    worker.kill()
    return jid


def test_sigkilled_worker_does_not_lose_job_embedded(
    tmp_path: Path, start_worker: Any, big_face: Path
) -> None:
    env = _env(tmp_path)
    w = start_worker(env, log=tmp_path / "worker1.log")
    svc = Service(tmp_path, env)
    jid = _kill_mid_reconstruct(svc, w, big_face)
    start_worker(env, log=tmp_path / "worker2.log")
    job = svc.finished(jid, timeout=180)
    assert job["state"] == "succeeded", job
    row = svc.store.get_job(jid)
    assert row is not None and row.requeues >= 1 and row.attempts >= 4  # reconstruct ran twice
    X, _ = read_mesh(svc.client.get(f"/v1/jobs/{jid}/artifacts/reconstruction.obj").content, "obj")
    V, _ = read_mesh(big_face)
    assert X.shape == V.shape and np.isfinite(X).all()


@pytest.mark.redis
def test_sigkilled_worker_job_redelivered_by_redis(
    tmp_path: Path, start_worker: Any, big_face: Path, redis_url: str
) -> None:
    # the job store's requeue is off: only Redis redelivery can bring the job back
    env = _env(
        tmp_path,
        CONFORMORPH_BROKER_URL=redis_url,
        CONFORMORPH_LEASE_REQUEUE="false",
        CONFORMORPH_REDIS_VISIBILITY_TIMEOUT="4",
        CONFORMORPH_REDIS_RESTORE_INTERVAL="1",
    )
    w = start_worker(env, log=tmp_path / "worker1.log")
    svc = Service(tmp_path, env)
    jid = _kill_mid_reconstruct(svc, w, big_face)
    # the worst case of the kill: worker 1 was inside a restore scan and left kombu's
    # restore mutex behind (kombu's own expiry, 300 s, would block every restore)
    import redis

    expire = WorkerSettings().redis_unacked_mutex_expire
    redis.Redis.from_url(redis_url).set("unacked_mutex", "killed-holder", px=int(expire * 1000))
    start_worker(env, log=tmp_path / "worker2.log")
    job = svc.finished(jid, timeout=60 + expire)
    assert job["state"] == "succeeded", job
    row = svc.store.get_job(jid)
    assert row is not None and row.requeues == 0 and row.attempts >= 4


@pytest.mark.rabbitmq
def test_sigkilled_worker_job_redelivered_by_rabbitmq(
    tmp_path: Path, start_worker: Any, big_face: Path, amqp_url: str
) -> None:
    # the job store's requeue is off: only RabbitMQ's redelivery of the dead connection's
    # unacknowledged message (late acks) can bring the job back
    env = _env(tmp_path, CONFORMORPH_BROKER_URL=amqp_url, CONFORMORPH_LEASE_REQUEUE="false")
    w = start_worker(env, log=tmp_path / "worker1.log")
    svc = Service(tmp_path, env)
    jid = _kill_mid_reconstruct(svc, w, big_face)
    start_worker(env, log=tmp_path / "worker2.log")
    job = svc.finished(jid, timeout=120)
    assert job["state"] == "succeeded", job
    row = svc.store.get_job(jid)
    assert row is not None and row.requeues == 0 and row.attempts >= 4  # reconstruct ran twice
    X, _ = read_mesh(svc.client.get(f"/v1/jobs/{jid}/artifacts/reconstruction.obj").content, "obj")
    V, _ = read_mesh(big_face)
    assert X.shape == V.shape and np.isfinite(X).all()


def test_cancel_running_job(
    tmp_path: Path, start_worker: Any, big_face: Path, small_face_path: Path
) -> None:
    env = _env(tmp_path)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    mid = svc.upload(big_face)
    jid = svc.submit("/v1/reconstructions", {"mesh": mid, "curvature": "scalar"})
    running = svc.wait(
        jid, lambda j: j.state == "running" and j.stage == "reconstruct", timeout=180
    )
    r = svc.client.delete(f"/v1/jobs/{jid}")
    assert r.status_code == 200 and r.json()["state"] == "cancelled"
    # the running stage notices and stops: its task ends (ignored) long before the
    # several seconds the reconstruction needs, and nothing of it is written
    t_cancel = time.monotonic()
    deadline = t_cancel + 20
    while f"{running.task_id}] ignored" not in (tmp_path / "worker.log").read_text():
        assert time.monotonic() < deadline, "the running stage did not stop"
        time.sleep(0.05)
    stopped_after = time.monotonic() - t_cancel
    assert stopped_after < 10.0, stopped_after
    # the worker goes on serving: a new job succeeds, and the cancelled one stays cancelled
    small = svc.upload(small_face_path)
    ok = svc.submit("/v1/conformal-maps", {"mesh": small})
    assert svc.finished(ok)["state"] == "succeeded"
    time.sleep(1.0)
    job = svc.client.get(f"/v1/jobs/{jid}").json()
    assert job["state"] == "cancelled"
    assert "reconstruction.obj" not in {a["name"] for a in job["artifacts"]}
    assert not list((tmp_path / "artifacts" / "jobs" / jid).rglob("reconstruction.obj"))


@pytest.fixture(autouse=True)
def _no_stray_env(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    for k in list(os.environ):
        if k.startswith("CONFORMORPH_"):
            monkeypatch.delenv(k)
    yield


def test_embedded_face_morph_and_2d_morph(tmp_path: Path, start_worker: Any) -> None:
    from tests.service.test_morphs import SHAPES

    env = _env(tmp_path)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    V, F = small_face(10)
    W = V.copy()
    W[:, 2] += 3.0 * np.sin(V[:, 0] / 30.0)
    write_obj(tmp_path / "a.obj", V, F)
    write_obj(tmp_path / "b.obj", W, F)
    r = np.linalg.norm(V[:, :2] / np.array([80.0, 100.0]), axis=1)
    ring = np.flatnonzero(np.abs(r - 0.5) < 0.02)
    lm = [0, *[int(i) for i in ring[:: max(1, ring.size // 8)][:8]]]
    ids = [svc.upload(tmp_path / "a.obj"), svc.upload(tmp_path / "b.obj")]
    face = svc.submit("/v1/morphs", {"meshes": ids, "landmarks": [lm, lm], "frames": 6})
    src = svc.client.post(
        "/v1/shapes", files={"file": ("s.json", (SHAPES / "bar_straight.json").read_bytes())}
    )
    dst = svc.client.post(
        "/v1/shapes", files={"file": ("t.json", (SHAPES / "bar_bent.json").read_bytes())}
    )
    assert src.status_code == dst.status_code == 201, src.text + dst.text
    anchors = json.loads((SHAPES / "bar_anchors.json").read_text())["anchors"]
    flat = svc.submit(
        "/v1/morphs2d",
        {"source": src.json()["id"], "target": dst.json()["id"], "anchors": anchors, "frames": 4},
    )
    job = svc.finished(face, timeout=120)
    assert job["state"] == "succeeded", job
    assert [s["state"] for s in job["stages"]] == ["done"] * 5
    glb = svc.client.get(f"/v1/jobs/{face}/artifacts/animation.glb")
    assert glb.content[:4] == b"glTF"
    job2 = svc.finished(flat, timeout=120)
    assert job2["state"] == "succeeded", job2
    assert svc.client.get(f"/v1/jobs/{flat}/artifacts/strip.svg").status_code == 200
    # each mesh's work: precomputed after its upload (conformorph.precompute_key, run by
    # the worker) or stored by the first job; the same meshes again find it
    got = svc.client.get(f"/v1/jobs/{face}/artifacts/metrics.json").json()
    assert {i["cache"]["state"] for i in got["inputs"]} <= {"hit", "stored"}
    again = svc.submit("/v1/morphs", {"meshes": ids, "landmarks": [lm, lm], "frames": 3})
    assert svc.finished(again, timeout=120)["state"] == "succeeded"
    got = svc.client.get(f"/v1/jobs/{again}/artifacts/metrics.json").json()
    assert [i["cache"]["state"] for i in got["inputs"]] == ["hit", "hit"]
    keys = list((tmp_path / "artifacts" / "keys").rglob("*.npz"))
    assert len(keys) == 2, keys
