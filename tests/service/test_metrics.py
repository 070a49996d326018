"""Tests of ``/metrics`` (service/metrics.py), scraped and parsed with prometheus_client's parser."""

from __future__ import annotations

import uuid
from typing import Any

import pytest
from prometheus_client.parser import text_string_to_metric_families

from conformorph.service.metrics import STAGE_BUCKETS, broker_queue_depths


def _scrape(api: Any) -> dict[str, dict[tuple[tuple[str, str], ...], float]]:
    """Sample name → {sorted labels: value}."""
    r = api.client.get("/metrics")
    assert r.status_code == 200, r.text
    assert r.headers["content-type"].startswith("text/plain; version=")
    out: dict[str, dict[tuple[tuple[str, str], ...], float]] = {}
    for family in text_string_to_metric_families(r.text):
        for s in family.samples:
            out.setdefault(s.name, {})[tuple(sorted(s.labels.items()))] = s.value
    return out


def _one(samples: dict[tuple[tuple[str, str], ...], float], **labels: str) -> float:
    return samples[tuple(sorted(labels.items()))]


def test_metrics_need_no_key_and_count_requests_by_route_template(make_api):
    api = make_api()
    _, key = api.store.create_key("alice")  # keys exist: /v1/ needs one
    auth = {"Authorization": f"Bearer {key}"}
    for _ in range(3):
        assert api.client.get("/healthz").status_code == 200
    assert api.client.get("/v1/jobs/abc", headers=auth).status_code == 404
    assert api.client.get("/v1/jobs/def", headers=auth).status_code == 404
    assert api.client.get("/v1/jobs/abc").status_code == 401  # refused before routing
    assert api.client.get("/no/such/path").status_code == 404
    m = _scrape(api)  # no key: still 200
    req = m["conformorph_http_requests_total"]
    assert _one(req, method="GET", route="/healthz", status="200") == 3
    assert _one(req, method="GET", route="/v1/jobs/{job_id}", status="404") == 2
    assert _one(req, method="GET", route="/v1/jobs/{job_id}", status="401") == 1
    assert _one(req, method="GET", route="<unmatched>", status="404") == 1
    assert not any(dict(k).get("route") == "/metrics" for k in req)  # scrapes are not counted
    hist = m["conformorph_http_request_duration_seconds_count"]
    assert _one(hist, method="GET", route="/v1/jobs/{job_id}") == 3
    buckets = m["conformorph_http_request_duration_seconds_bucket"]
    assert _one(buckets, method="GET", route="/healthz", le="+Inf") == 3
    assert api.client.post("/metrics").status_code == 405


def test_jobs_stage_durations_and_failures_come_from_the_job_store(api):
    store = api.store
    a, _ = store.create_job(owner="o", kind="reconstruction", params={})
    b, _ = store.create_job(owner="o", kind="reconstruction", params={})
    store.create_job(owner="o", kind="morph", params={})
    for job, seconds in ((a, 0.3), (b, 45.0)):
        assert store.claim_stage(job.id, "conformal_map", "w", 30.0, None).status == "claimed"
        store.complete_stage(
            job.id, "conformal_map", "w", seconds=seconds, artifacts={}, handoff_lease_seconds=30
        )
    store.fail_job(
        b.id, {"type": "time_limit", "message": "m", "field": None, "stage": "curvature"}
    )
    m = _scrape(api)
    assert _one(m["conformorph_job_store_up"]) == 1
    jobs = m["conformorph_jobs"]
    assert _one(jobs, kind="reconstruction", state="running") == 1  # one stage of three done
    assert _one(jobs, kind="reconstruction", state="failed") == 1
    assert _one(jobs, kind="morph", state="queued") == 1
    assert sum(jobs.values()) == 3
    count = m["conformorph_stage_duration_seconds_count"]
    assert _one(count, kind="reconstruction", stage="conformal_map") == 2
    total = m["conformorph_stage_duration_seconds_sum"]
    assert _one(total, kind="reconstruction", stage="conformal_map") == pytest.approx(45.3)
    bk = m["conformorph_stage_duration_seconds_bucket"]
    for le in STAGE_BUCKETS:
        want = (0.3 <= le) + (45.0 <= le)
        assert _one(bk, kind="reconstruction", stage="conformal_map", le=str(le)) == want
    fail = m["conformorph_stage_failures_total"]
    assert fail == {(("kind", "reconstruction"), ("stage", "curvature"), ("type", "time_limit")): 1}
    # the embedded broker reports no queue depth
    assert "conformorph_queue_depth" not in m


def test_job_store_outage_is_reported_not_raised(api, monkeypatch):
    def down() -> None:
        raise OSError("database unreachable")

    monkeypatch.setattr(api.store, "job_stats", down)
    m = _scrape(api)
    assert _one(m["conformorph_job_store_up"]) == 0 and "conformorph_jobs" not in m


def test_metrics_can_be_turned_off(make_api):
    api = make_api(metrics_enabled=False)
    r = api.client.get("/metrics")
    assert r.status_code == 404
    assert "conformorph_http_requests" not in r.text


def test_openapi_does_not_list_metrics(api):
    assert "/metrics" not in api.client.get("/openapi.json").json()["paths"]


@pytest.mark.redis
def test_queue_depth_from_redis(redis_url, tmp_path):
    from kombu import Connection

    from conformorph.service.core.config import Settings
    from conformorph.worker.celery_app import create_celery_app

    app = create_celery_app(Settings(data_dir=tmp_path, broker_url=redis_url))
    with Connection(redis_url) as conn:
        q = conn.SimpleQueue("jobs")
        for k in range(3):
            q.put({"k": k})
        q.close()
    assert broker_queue_depths(app, ["jobs", "never_declared"]) == {"jobs": 3, "never_declared": 0}


def test_queue_depth_from_rabbitmq(tmp_path):
    from kombu import Connection

    from conformorph.service.core.config import Settings
    from conformorph.worker.celery_app import create_celery_app

    url = "amqp://guest:guest@127.0.0.1:5672//"
    # a name of its own: checkouts testing side by side share the machine's RabbitMQ
    queue = f"conformorph_test_depth_{uuid.uuid4().hex}"
    try:
        # publisher confirms: each put returns once RabbitMQ holds the message, so the
        # count below is not read while the second one is still on its way
        conn = Connection(url, connect_timeout=2.0, transport_options={"confirm_publish": True})
        conn.ensure_connection(max_retries=1, timeout=2.0)
    except Exception as exc:  # noqa: BLE001 - no RabbitMQ here
        pytest.skip(f"RabbitMQ does not answer at {url} ({exc!r})")
    with conn:
        q = conn.SimpleQueue(queue)
        try:
            for k in range(2):
                q.put({"k": k})
            app = create_celery_app(Settings(data_dir=tmp_path, broker_url=url))
            depths = broker_queue_depths(app, [queue, queue + "_never"])
            assert depths == {queue: 2, queue + "_never": 0}
        finally:
            q.queue.delete()
            q.close()


def test_random_method_tokens_keep_metrics_bounded(make_api):
    """5,000 requests with random method tokens (no key needed) leave /metrics under 200 KB
    (issue 30: 11 MB, one series per token)."""
    import random
    import string

    api = make_api()
    rng = random.Random(30)
    before = len(api.client.get("/metrics").content)
    for _ in range(5_000):
        token = "".join(rng.choices(string.ascii_uppercase, k=rng.randint(3, 12)))
        api.client.request(token, "/healthz")
    size = len(api.client.get("/metrics").content)
    assert size < 200_000, f"/metrics grew from {before} to {size} bytes"
    req = _scrape(api)["conformorph_http_requests_total"]
    assert {dict(k)["method"] for k in req} <= {"GET", "OTHER"}
    assert sum(v for k, v in req.items() if dict(k)["method"] == "OTHER") == 5_000
