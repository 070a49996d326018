"""The client against recorded server answers (pytest-httpx replays them).

The answers in ``tests/fixtures/client_recorded/exchanges.json`` were recorded
from a live ``conformorph serve`` by ``tests/fixtures/record_client_responses.py``;
every expectation below is read from the recorded bodies, not typed in.
"""

from __future__ import annotations

import asyncio
import base64
import json
from pathlib import Path
from typing import Any

import httpx
import pytest
from pytest_httpx import HTTPXMock

from conformorph_client import (
    ApiError,
    AsyncClient,
    Client,
    Conflict,
    InvalidInput,
    JobCancelled,
    JobFailed,
    NotFound,
    ServerError,
    TooManyJobs,
    TransportError,
    Unauthorized,
)
from conformorph_client._flows import SSEParser
from conformorph_client.errors import error_from_response
from conformorph_client.models import JobPublic, MeshPublic

RECORDED = Path(__file__).resolve().parents[1] / "fixtures" / "client_recorded" / "exchanges.json"
SMALL_FACE = Path(__file__).resolve().parents[1] / "fixtures" / "service_small_face.obj"
BASE = "http://conformorph.test"
EX: dict[str, dict[str, Any]] = json.loads(RECORDED.read_text())["exchanges"]


def _content(name: str) -> bytes:
    ex = EX[name]
    return base64.b64decode(ex["base64"]) if "base64" in ex else ex["text"].encode()


def _json(name: str) -> Any:
    return json.loads(EX[name]["text"])


def replay(
    mock: HTTPXMock, name: str, *, method: str | None = None, path: str | None = None, **kw: Any
) -> None:
    """Answer the next matching request with the recorded exchange ``name``."""
    ex = EX[name]
    mock.add_response(
        method=method or ex["method"],
        url=BASE + (path or ex["path"]),
        status_code=ex["status"],
        headers=ex["headers"],
        content=_content(name),
        **kw,
    )


@pytest.fixture
def client() -> Any:
    with Client(BASE) as c:
        yield c


def test_health_and_readiness(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "healthz")
    replay(httpx_mock, "readyz")
    assert client.healthz().status == _json("healthz")["status"]
    ready = client.readyz()
    assert ready.status == "ready" and ready.checks == _json("readyz")["checks"]


def test_upload_sends_multipart_file_and_parses_both_answers(
    client: Client, httpx_mock: HTTPXMock
) -> None:
    replay(httpx_mock, "upload_mesh_created")
    replay(httpx_mock, "upload_mesh_again")
    first = client.upload_mesh(SMALL_FACE)
    again = client.upload_mesh(("face.obj", SMALL_FACE.read_bytes()))
    assert isinstance(first, MeshPublic) and first.id == again.id == _json("get_mesh")["id"]
    assert first.vertices == _json("upload_mesh_created")["vertices"]
    requests = httpx_mock.get_requests()
    assert len(requests) == 2
    for req in requests:
        assert req.headers["content-type"].startswith("multipart/form-data")
        body = req.read()
        assert b'name="file"' in body and SMALL_FACE.read_bytes() in body
    assert b'filename="service_small_face.obj"' in requests[0].read()


@pytest.mark.parametrize(
    ("name", "exc_type"),
    [
        ("upload_mesh_invalid", InvalidInput),
        ("upload_mesh_bad_type", InvalidInput),
        ("get_mesh_missing", NotFound),
        ("create_conformal_map_conflict", Conflict),
        ("create_conformal_map_invalid", InvalidInput),
        ("artifact_missing", NotFound),
        ("get_job_missing", NotFound),
        ("no_key", Unauthorized),
        ("wrong_key", Unauthorized),
        ("too_many_jobs", TooManyJobs),
    ],
)
def test_errors_are_typed_and_carry_the_servers_message(
    name: str, exc_type: type[ApiError], client: Client, httpx_mock: HTTPXMock
) -> None:
    ex = EX[name]
    path = ex["path"]
    # the client always sends the paging parameters
    replay(httpx_mock, name, path=path + "?limit=50&offset=0" if path == "/v1/jobs" else path)
    with pytest.raises(exc_type) as info:
        if path == "/v1/meshes":
            client.upload_mesh(("bad.obj", b"v 0 0 0\n"))
        elif path.startswith("/v1/meshes/"):
            client.get_mesh(path.rsplit("/", 1)[1])
        elif path == "/v1/conformal-maps":
            client.create_conformal_map("m", idempotency_key="k")
        elif "/artifacts/" in path:
            job_id, _, art = path.removeprefix("/v1/jobs/").partition("/artifacts/")
            client.get_artifact(job_id, art)
        elif path.startswith("/v1/jobs/"):
            client.get_job(path.rsplit("/", 1)[1])
        else:
            client.list_jobs(limit=50)
    err = info.value
    expected = _json(name)["error"]
    assert (err.status, err.type, err.message, err.field) == (
        ex["status"],
        expected["type"],
        expected["message"],
        expected["field"],
    )
    assert expected["message"] in str(err)
    if isinstance(err, TooManyJobs):
        assert err.retry_after == float(ex["headers"]["retry-after"])


def test_submit_sends_body_and_idempotency_key(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "create_conformal_map")
    mesh_id = EX["create_conformal_map"]["json"]["mesh"]
    job = client.create_conformal_map(mesh_id, idempotency_key="rec-1")
    assert job.id == _json("create_conformal_map")["id"] and job.state == "queued"
    req = httpx_mock.get_request()
    assert req is not None
    assert req.headers["Idempotency-Key"] == "rec-1"
    assert json.loads(req.read()) == EX["create_conformal_map"]["json"]


def test_morph_body_leaves_unset_parameters_to_the_server(
    client: Client, httpx_mock: HTTPXMock
) -> None:
    # the answer is a recorded job; the point is the request body
    replay(httpx_mock, "create_reconstruction", method="POST", path="/v1/morphs")
    client.create_morph(["a", "b"], landmarks=[[1, 2, 3], [4, 5, 6]], frames=12)
    req = httpx_mock.get_request()
    assert req is not None
    assert json.loads(req.read()) == {
        "meshes": ["a", "b"],
        "landmarks": [[1, 2, 3], [4, 5, 6]],
        "frames": 12,
    }


def test_api_key_is_sent_as_bearer(httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "healthz")
    with Client(BASE, api_key="sekrit") as c:
        c.healthz()
    req = httpx_mock.get_request()
    assert req is not None and req.headers["Authorization"] == "Bearer sekrit"


def test_open_client_sends_no_authorization(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "healthz")
    client.healthz()
    req = httpx_mock.get_request()
    assert req is not None and "Authorization" not in req.headers


def test_sse_parser_reads_the_recorded_stream() -> None:
    parser = SSEParser()
    events = [e for line in EX["events"]["text"].split("\n") if (e := parser.feed(line))]
    names = [e[0] for e in events]
    assert names[-1] == "end" and set(names[:-1]) == {"state"}
    jobs = [JobPublic.model_validate_json(d) for n, d in events if n == "state"]
    progress = [j.progress for j in jobs]
    assert progress == sorted(progress) and jobs[-1].state == "succeeded"


def test_events_and_wait_follow_the_job(client: Client, httpx_mock: HTTPXMock) -> None:
    job_id = _json("get_job_succeeded")["id"]
    first_state = json.loads(
        next(
            line.removeprefix("data: ")
            for line in EX["events"]["text"].splitlines()
            if line.startswith('data: {"')
        )
    )
    httpx_mock.add_response(url=f"{BASE}/v1/jobs/{job_id}", json=first_state)
    replay(httpx_mock, "events")
    replay(httpx_mock, "get_job_succeeded")
    seen: list[JobPublic] = []
    job = client.wait(job_id, on_update=seen.append)
    assert job.state == "succeeded" and [a.name for a in job.artifacts] == [
        a["name"] for a in _json("get_job_succeeded")["artifacts"]
    ]
    assert seen[0].state == first_state["state"] and seen[-1].state == "succeeded"
    assert [s.progress for s in seen] == sorted(s.progress for s in seen)


def test_wait_raises_on_a_cancelled_job(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "get_job_cancelled")
    job_id = _json("get_job_cancelled")["id"]
    with pytest.raises(JobCancelled) as info:
        client.wait(job_id)
    assert info.value.job.state == "cancelled"
    replay(httpx_mock, "get_job_cancelled")
    assert client.wait(job_id, raise_on_failure=False).state == "cancelled"


def test_cancel_and_delete(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "cancel_job")
    cancelled = client.cancel_job(_json("cancel_job")["id"])
    assert cancelled is not None and cancelled.state == "cancelled"
    replay(httpx_mock, "delete_job_finished", method="DELETE")
    assert client.delete_job(EX["delete_job_finished"]["path"].rsplit("/", 1)[1]) is None


def test_list_and_iterate_pages(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "list_jobs")
    replay(httpx_mock, "list_jobs_page2")
    jobs = list(client.iter_jobs(page_size=1))
    total = _json("list_jobs")["total"]
    assert len(jobs) == total == 2
    assert [j.id for j in jobs] == [
        _json("list_jobs")["items"][0]["id"],
        _json("list_jobs_page2")["items"][0]["id"],
    ]


def test_artifacts_whole_range_and_download(
    client: Client, httpx_mock: HTTPXMock, tmp_path: Path
) -> None:
    path = EX["artifact_quality"]["path"]
    job_id, _, name = path.removeprefix("/v1/jobs/").partition("/artifacts/")
    replay(httpx_mock, "artifact_quality")
    replay(httpx_mock, "artifact_range", match_headers={"Range": EX["artifact_range"]["range"]})
    replay(httpx_mock, "artifact_quality")
    whole = client.get_artifact(job_id, name)
    assert whole == _content("artifact_quality")
    part = client.get_artifact(job_id, name, byte_range=(0, 9))
    assert part == whole[:10]
    dest = client.download(job_id, name, tmp_path / "sub" / name)
    assert dest.read_bytes() == whole
    assert not (tmp_path / "sub" / f"{name}.part").exists()


def test_failed_download_leaves_no_file(
    client: Client, httpx_mock: HTTPXMock, tmp_path: Path
) -> None:
    replay(httpx_mock, "artifact_missing")
    path = EX["artifact_missing"]["path"]
    job_id, _, name = path.removeprefix("/v1/jobs/").partition("/artifacts/")
    with pytest.raises(NotFound):
        client.download(job_id, name, tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_connection_failure_is_a_transport_error(client: Client, httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_exception(httpx.ConnectError("connection refused"))
    with pytest.raises(TransportError, match="connection refused"):
        client.healthz()


def test_non_json_and_problem_details_errors() -> None:
    req = httpx.Request("GET", BASE)
    proxy = httpx.Response(502, text="Bad Gateway from proxy", request=req)
    err = error_from_response(proxy)
    assert isinstance(err, ServerError) and err.message == "Bad Gateway from proxy"
    problem = httpx.Response(
        422, json={"type": "about:blank", "title": "Invalid", "detail": "frames too large"}
    )
    err = error_from_response(problem)
    assert isinstance(err, InvalidInput) and err.message == "frames too large"


def test_ids_cannot_change_the_route(client: Client, httpx_mock: HTTPXMock) -> None:
    httpx_mock.add_response(
        url=f"{BASE}/v1/jobs/..%2Fmeshes", status_code=404, json=_json("get_job_missing")
    )
    with pytest.raises(NotFound):
        client.get_job("../meshes")
    with pytest.raises(ValueError):
        client.get_job("")


def test_async_client_same_calls(httpx_mock: HTTPXMock, tmp_path: Path) -> None:
    job_id = _json("get_job_succeeded")["id"]
    replay(httpx_mock, "upload_mesh_created")
    replay(httpx_mock, "create_conformal_map")
    replay(httpx_mock, "get_job_succeeded")
    replay(httpx_mock, "artifact_quality")
    replay(httpx_mock, "get_mesh_missing")
    replay(httpx_mock, "too_many_jobs")

    async def run() -> None:
        async with AsyncClient(BASE) as c:
            mesh = await c.upload_mesh(SMALL_FACE)
            job = await c.create_conformal_map(mesh.id)
            assert job.state == "queued"
            done = await c.wait(job_id)
            assert done.state == "succeeded"
            dest = await c.download(job_id, "quality.json", tmp_path / "q.json")
            assert dest.read_bytes() == _content("artifact_quality")
            with pytest.raises(NotFound) as info:
                await c.get_mesh("0000")
            assert info.value.message == _json("get_mesh_missing")["error"]["message"]
            with pytest.raises(TooManyJobs):
                await c.create_conformal_map(mesh.id)

    asyncio.run(run())


def test_async_wait_follows_events(httpx_mock: HTTPXMock) -> None:
    job_id = _json("get_job_succeeded")["id"]
    replay(httpx_mock, "get_job_queued", path=f"/v1/jobs/{job_id}")
    replay(httpx_mock, "events")
    replay(httpx_mock, "get_job_succeeded")
    seen: list[JobPublic] = []

    async def run() -> JobPublic:
        async with AsyncClient(BASE) as c:
            return await c.wait(job_id, on_update=seen.append)

    assert asyncio.run(run()).state == "succeeded"
    assert seen[-1].state == "succeeded" and len(seen) >= 3


def test_morph_submission_and_its_stages(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "create_morph")
    body = EX["create_morph"]["json"]
    job = client.create_morph(body["meshes"], landmarks=body["landmarks"], frames=body["frames"])
    req = httpx_mock.get_request()
    assert req is not None and json.loads(req.read()) == body
    assert job.kind == "morph" and job.state == "queued"
    assert [s.name for s in job.stages] == [s["name"] for s in _json("create_morph")["stages"]]
    # first look: the job as the submission answered it (queued)
    httpx_mock.add_response(url=f"{BASE}/v1/jobs/{job.id}", json=_json("create_morph"))
    replay(httpx_mock, "morph_events", path=f"/v1/jobs/{job.id}/events")
    replay(httpx_mock, "get_morph_succeeded", path=f"/v1/jobs/{job.id}")
    done = client.wait(job.id)
    assert done.state == "succeeded" and {"animation.glb", "metrics.json"} <= {
        a.name for a in done.artifacts
    }
    seen_stages = {
        JobPublic.model_validate_json(line.removeprefix("data: ")).stage
        for line in EX["morph_events"]["text"].splitlines()
        if line.startswith('data: {"')
    }
    assert seen_stages <= {s.name for s in done.stages} | {None}


def test_failed_morph_raises_job_failed_with_the_servers_reason(
    client: Client, httpx_mock: HTTPXMock
) -> None:
    replay(httpx_mock, "get_morph_failed")
    failed = _json("get_morph_failed")
    with pytest.raises(JobFailed) as info:
        client.wait(failed["id"])
    err = info.value
    assert (err.type, err.message, err.field, err.stage) == (
        failed["error"]["type"],
        failed["error"]["message"],
        failed["error"]["field"],
        failed["error"]["stage"],
    )
    assert failed["error"]["message"] in str(err)


def test_morph_limits_are_typed_errors(client: Client, httpx_mock: HTTPXMock) -> None:
    replay(httpx_mock, "create_morph_too_many_frames")
    with pytest.raises(InvalidInput) as info:
        client.create_morph(["a", "b"], landmarks=[[1, 2, 3]] * 2, frames=10**6)
    assert info.value.field == "frames"
    assert info.value.message == _json("create_morph_too_many_frames")["error"]["message"]


def test_every_api_operation_has_a_client_method() -> None:
    spec = json.loads(
        (Path(__file__).resolve().parents[2] / "openapi" / "openapi.json").read_text()
    )
    aliases = {"job_events": "events"}
    ops = {op["operationId"] for path in spec["paths"].values() for op in path.values()}
    assert len(ops) >= 15
    for op in sorted(ops):
        name = aliases.get(op, op)
        hint = (
            "add the endpoint to conformorph_client (a builder in _calls.py, listed in client.py)"
        )
        assert callable(getattr(Client, name, None)), f"Client lacks {name} ({op}): {hint}"
        assert callable(getattr(AsyncClient, name, None)), f"AsyncClient lacks {name}: {hint}"
