"""Webhook fields on the job routes: checked at submission (422), shown on the job
without the secret, delivered by the worker-side function once the job ends."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from conformorph.worker.callbacks import SIGNATURE_HEADER, TIMESTAMP_HEADER, verify_signature
from conformorph.worker.celery_app import create_celery_app
from conformorph.worker.webhooks import deliver_job_callback, dispatch_due_callbacks
from tests.service.conftest import Api
from tests.webhook_receiver import webhook_receiver

SECRET = "correct horse battery staple"
ALLOW_LOOPBACK = "public,127.0.0.0/8"


def _queued(api: Api) -> list[str]:
    """Task names of the messages waiting on the embedded broker of ``api``."""
    folder = api.settings.broker_dir / "queue"
    return [json.loads(p.read_text())["headers"]["task"] for p in sorted(folder.iterdir())]


def _mesh(api: Api, path: Path) -> str:
    r = api.upload(path)
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


@pytest.mark.parametrize(
    ("url", "why"),
    [
        ("http://127.0.0.1:9/hook", "127.0.0.1"),
        ("http://10.0.0.1/hook", "10.0.0.1"),
        ("http://169.254.169.254/latest/meta-data", "169.254.169.254"),
        ("http://[::1]/hook", "::1"),
        ("http://localhost/hook", "localhost"),
        ("ftp://8.8.8.8/x", "http or https"),
        ("http://u:p@8.8.8.8/x", "user info"),
        ("http://[::1", "not a valid URL"),
        ("http://[", "not a valid URL"),
        ("https://[x]", "not a valid URL"),
        ("http://]", "not a valid URL"),
        ("http://[2002:7f00:1::]/hook", "2002:7f00:1::"),
        ("http://[64:ff9b::7f00:1]/hook", "64:ff9b::7f00:1"),
    ],
)
def test_disallowed_callback_is_refused_at_submission(
    api: Api, small_face_path: Path, url: str, why: str
) -> None:
    mesh = _mesh(api, small_face_path)
    r = api.client.post("/v1/conformal-maps", json={"mesh": mesh, "callback_url": url})
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["type"] == "callback_not_allowed" and err["field"] == "callback_url"
    assert why in err["message"]
    assert api.tasks.submitted == [] and api.store.list_jobs("open")[1] == 0


def test_secret_needs_url_and_a_length(api: Api, small_face_path: Path) -> None:
    mesh = _mesh(api, small_face_path)
    r = api.client.post("/v1/conformal-maps", json={"mesh": mesh, "callback_secret": SECRET})
    assert r.status_code == 422 and r.json()["error"]["field"] == "callback_secret"
    r = api.client.post(
        "/v1/conformal-maps",
        json={"mesh": mesh, "callback_url": "https://8.8.8.8/h", "callback_secret": "short"},
    )
    assert r.status_code == 422, r.text


def test_every_job_route_takes_the_callback_fields(api: Api) -> None:
    spec = api.client.get("/openapi.json").json()
    schemas = spec["components"]["schemas"]
    for path in ("/v1/conformal-maps", "/v1/reconstructions", "/v1/morphs", "/v1/morphs2d"):
        ref = spec["paths"][path]["post"]["requestBody"]["content"]["application/json"]["schema"]
        props = schemas[ref["$ref"].rsplit("/", 1)[1]]["properties"]
        assert {"callback_url", "callback_secret"} <= set(props), path
        assert "X-Conformorph-Signature" in props["callback_secret"]["description"]


def test_job_with_callback_is_delivered_once_signed(make_api: Any, small_face_path: Path) -> None:
    api = make_api(callback_allow=ALLOW_LOOPBACK)
    mesh = _mesh(api, small_face_path)
    with webhook_receiver() as rx:
        r = api.client.post(
            "/v1/conformal-maps",
            json={"mesh": mesh, "callback_url": rx.url, "callback_secret": SECRET},
        )
        assert r.status_code == 202, r.text
        job = r.json()
        assert SECRET not in r.text
        assert job["callback"] == {
            "url": rx.url,
            "signed": True,
            "status": "pending",
            "attempts": [],
        }
        assert job["params"]["callback_url"] == rx.url
        app = create_celery_app(api.settings)  # the embedded broker under tmp_path
        # not ended yet: nothing is due
        assert dispatch_due_callbacks(api.store, app, api.settings) == []
        api.run_job(job["id"])
        assert dispatch_due_callbacks(api.store, app, api.settings) == [job["id"]]
        assert _queued(api) == ["conformorph.deliver_callback"]
        # on the webhooks' own queue: a slow receiver never holds a validation (issue 30)
        (message,) = (api.settings.broker_dir / "queue").iterdir()
        assert message.name.endswith(".conformorph-webhooks.msg")
        # taken: a second sweep (another worker) does not send it again
        assert dispatch_due_callbacks(api.store, app, api.settings) == []
        assert len(_queued(api)) == 1
        out = deliver_job_callback(api.store, api.settings, job["id"])
        assert (out.status, out.retry_in) == ("delivered", None)
        # a duplicated task delivers nothing more
        assert deliver_job_callback(api.store, api.settings, job["id"]).status == "skipped"
        (got,) = rx.wait_for(1)
    h = got.headers
    assert verify_signature(SECRET, h[TIMESTAMP_HEADER], got.body, h[SIGNATURE_HEADER])
    body = json.loads(got.body)
    public = api.client.get(f"/v1/jobs/{job['id']}").json()
    assert body["state"] == "succeeded" and body["id"] == job["id"]
    assert body["artifacts"] == public["artifacts"]
    cb = public["callback"]
    assert cb["status"] == "delivered" and len(cb["attempts"]) == 1
    assert cb["attempts"][0]["status_code"] == 200 and cb["attempts"][0]["state"] == "succeeded"
    assert SECRET not in api.client.get(f"/v1/jobs/{job['id']}").text
    assert SECRET not in api.client.get("/v1/jobs").text


def test_fails_twice_then_succeeds_three_attempts(make_api: Any, small_face_path: Path) -> None:
    api = make_api(callback_allow=ALLOW_LOOPBACK, callback_backoff_seconds=0.5)
    mesh = _mesh(api, small_face_path)
    with webhook_receiver([503, 500]) as rx:
        r = api.client.post("/v1/conformal-maps", json={"mesh": mesh, "callback_url": rx.url})
        job_id = r.json()["id"]
        api.client.delete(f"/v1/jobs/{job_id}")  # cancelled: a terminal state too
        outs = [deliver_job_callback(api.store, api.settings, job_id) for _ in range(3)]
        rx.wait_for(3)
    assert [(o.status, o.retry_in) for o in outs] == [
        ("pending", 0.5),
        ("pending", 1.0),
        ("delivered", None),
    ]
    cb = api.client.get(f"/v1/jobs/{job_id}").json()["callback"]
    assert [a["outcome"] for a in cb["attempts"]] == ["retry", "retry", "delivered"]
    assert [a["status_code"] for a in cb["attempts"]] == [503, 500, 200]
    assert [a["attempt"] for a in cb["attempts"]] == [1, 2, 3]
    assert {a["state"] for a in cb["attempts"]} == {"cancelled"}
    assert all(json.loads(r.body)["state"] == "cancelled" for r in rx.requests)


def test_gives_up_after_max_attempts(make_api: Any, small_face_path: Path) -> None:
    api = make_api(callback_allow=ALLOW_LOOPBACK, callback_max_attempts=2)
    mesh = _mesh(api, small_face_path)
    with webhook_receiver(default=502) as rx:
        job_id = api.client.post(
            "/v1/conformal-maps", json={"mesh": mesh, "callback_url": rx.url}
        ).json()["id"]
        api.client.delete(f"/v1/jobs/{job_id}")
        outs = [deliver_job_callback(api.store, api.settings, job_id) for _ in range(3)]
    assert [o.status for o in outs] == ["pending", "failed", "skipped"]
    assert len(rx.requests) == 2


def test_a_destination_refused_at_delivery_is_final(make_api: Any, small_face_path: Path) -> None:
    api = make_api(callback_allow=ALLOW_LOOPBACK)
    mesh = _mesh(api, small_face_path)
    with webhook_receiver() as rx:
        job_id = api.client.post(
            "/v1/conformal-maps", json={"mesh": mesh, "callback_url": rx.url}
        ).json()["id"]
        api.client.delete(f"/v1/jobs/{job_id}")
        api.settings.callback_allow = ""  # the operator narrowed the allow-list since
        out = deliver_job_callback(api.store, api.settings, job_id)
    assert out.status == "failed" and rx.requests == []
    (attempt,) = api.client.get(f"/v1/jobs/{job_id}").json()["callback"]["attempts"]
    assert attempt["outcome"] == "refused" and "127.0.0.1" in attempt["error"]


def test_jobs_without_callback_have_none(api: Api, small_face_path: Path) -> None:
    mesh = _mesh(api, small_face_path)
    job = api.client.post("/v1/conformal-maps", json={"mesh": mesh}).json()
    assert job["callback"] is None and "callback_url" not in job["params"]
    assert api.store.get_callback(job["id"]) is None
