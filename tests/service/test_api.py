"""In-process tests of every endpoint and error (real validation and real stages, no broker)."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image

from conformorph.pipelines.mesh_io import read_mesh
from tests.service.conftest import Api

TETRA = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n"


def _error(r: object) -> dict[str, object]:
    body = r.json()  # type: ignore[attr-defined]
    assert set(body) == {"error"}, body
    assert {"type", "message", "field"} <= set(body["error"]), body
    return body["error"]  # type: ignore[no-any-return]


def _upload_ok(api: Api, path: Path) -> str:
    r = api.upload(path)
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def _submit(api: Api, route: str, body: dict[str, object], **headers: str) -> dict[str, object]:
    r = api.client.post(route, json=body, headers=headers)
    assert r.status_code == 202, r.text
    assert r.headers["location"] == f"/v1/jobs/{r.json()['id']}"
    return r.json()  # type: ignore[no-any-return]


def test_health_and_readiness(api: Api) -> None:
    assert api.client.get("/healthz").json() == {"status": "ok"}
    r = api.client.get("/readyz")
    assert r.status_code == 200
    assert r.json()["checks"] == {
        "job_store": True,
        "storage": True,
        "broker": True,
        "validation_workers": True,
    }


def test_upload_mesh_reports_counts_and_is_content_addressed(
    api: Api, small_face_path: Path
) -> None:
    V, F = read_mesh(small_face_path)
    r = api.upload(small_face_path)
    assert r.status_code == 201, r.text
    body = r.json()
    assert (body["vertices"], body["faces"]) == (V.shape[0], F.shape[0])
    assert body["boundary_loops"] == 1 and body["euler_characteristic"] == 1
    again = api.upload(small_face_path, name="renamed.obj")
    assert again.status_code == 200 and again.json()["id"] == body["id"]
    assert api.client.get(f"/v1/meshes/{body['id']}").json()["id"] == body["id"]
    # the stored copy is byte-identical to the upload
    stored = api.storage.read_bytes(api.store.get_mesh("open", body["id"]).storage_key)  # type: ignore[union-attr]
    assert stored == small_face_path.read_bytes()


def test_upload_errors_are_json_4xx(
    make_api: object, tmp_path: Path, small_face_path: Path
) -> None:
    api: Api = make_api(max_upload_bytes=20_000, max_vertices=100)  # type: ignore[operator]
    cases = {
        "mesh.txt": (b"v 0 0 0\n", 422, "unsupported_file_type"),
        "empty.obj": (b"", 422, "empty_file"),
        "tetra.obj": (TETRA, 422, None),
        "junk.ply": (b"this is not a ply file at all", 422, None),
    }
    for name, (data, status, etype) in cases.items():
        r = api.client.post("/v1/meshes", files={"file": (name, data)})
        assert r.status_code == status, (name, r.text)
        err = _error(r)
        assert err["field"] == "file"
        if etype:
            assert err["type"] == etype
    # closed surface: not a disk, said plainly
    r = api.client.post("/v1/meshes", files={"file": ("tetra.obj", TETRA)})
    assert (
        "boundary" in str(_error(r)["message"]).lower()
        or "disk" in str(_error(r)["message"]).lower()
    )
    # over the vertex limit (331 > 100): 422
    r = api.upload(small_face_path)
    assert r.status_code == 422 and _error(r)["type"] == "mesh_too_large"
    # over the byte limit: 413 before anything is stored
    big = tmp_path / "big.obj"
    big.write_bytes(small_face_path.read_bytes() * 10)
    r = api.upload(big)
    assert r.status_code == 413 and _error(r)["type"] == "payload_too_large"
    assert list(api.storage.iter_keys("meshes")) == []  # type: ignore[attr-defined]
    r = api.client.post("/v1/meshes", files={"nofile": ("a.obj", b"x")})
    assert r.status_code == 422 and _error(r)["field"] == "file"


def test_face_limit(make_api: object, small_face_path: Path) -> None:
    _, F = read_mesh(small_face_path)
    api: Api = make_api(max_faces=F.shape[0] - 1)  # type: ignore[operator]
    r = api.upload(small_face_path)
    assert r.status_code == 422 and _error(r)["type"] == "mesh_too_large", r.text
    assert f"{F.shape[0]} faces" in str(_error(r)["message"]) and _error(r)["field"] == "file"
    assert list(api.storage.iter_keys("meshes")) == []  # type: ignore[attr-defined]
    at_limit: Api = make_api(max_faces=F.shape[0])  # type: ignore[operator]
    assert at_limit.upload(small_face_path).status_code == 201


def _chunks(data: bytes, size: int = 1000) -> object:
    # an iterator body: sent without Content-Length, so the middleware has to count
    return (data[i : i + size] for i in range(0, len(data), size))


def test_every_json_body_has_a_size_limit(make_api: object) -> None:
    api: Api = make_api(max_landmark_bytes=3000, max_json_bytes=2000)  # type: ignore[operator]
    pad = {"landmarks": [[0, 1, 2], [0, 1, 2]], "note": "x" * 2500}  # ~2.5 kB
    routes = {
        "/v1/landmarks": 3000,
        "/v1/morphs": 3000,
        "/v1/morphs2d": 2000,
        "/v1/conformal-maps": 2000,
        "/v1/reconstructions": 2000,
    }
    for route, limit in routes.items():
        big = json.dumps({**pad, "note": "x" * (limit + 10)}).encode()
        for content in (big, _chunks(big)):
            r = api.client.post(
                route, content=content, headers={"content-type": "application/json"}
            )  # type: ignore[arg-type]
            assert r.status_code == 413, (route, r.text)
            err = _error(r)
            assert err["type"] == "payload_too_large" and f"{limit} bytes" in str(err["message"])
            assert err["field"] is None
    # under the landmark limit but over the other JSON limit: a landmark document is fine
    doc = json.dumps(pad).encode()
    assert 2000 < len(doc) < 3000
    for content in (doc, _chunks(doc)):
        r = api.client.post(
            "/v1/landmarks", content=content, headers={"content-type": "application/json"}
        )  # type: ignore[arg-type]
        assert r.status_code in (200, 201), r.text
    r = api.client.post(
        "/v1/conformal-maps", content=doc, headers={"content-type": "application/json"}
    )
    assert r.status_code == 413
    # an upload route keeps its own limit and names the file
    r = api.client.post("/v1/meshes", files={"file": ("a.obj", b"v 0 0 0\n" * 10)})
    assert r.status_code == 422 and _error(r)["field"] == "file"
    assert api.tasks.submitted == []


def test_conformal_map_job_end_to_end(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    job = _submit(api, "/v1/conformal-maps", {"mesh": mid})
    assert job["state"] == "queued" and job["progress"] == 0
    assert api.tasks.submitted == [(job["id"], ["conformal_map"])]
    outs = api.run_job(str(job["id"]))
    assert [o.status for o in outs] == ["ran"]
    got = api.client.get(f"/v1/jobs/{job['id']}").json()
    assert got["state"] == "succeeded" and got["progress"] == 1.0
    assert got["stages"][0]["state"] == "done" and got["stages"][0]["seconds"] > 0
    names = {a["name"]: a for a in got["artifacts"]}
    assert set(names) == {
        "disk_map.npz",
        "quality.json",
        "angle_distortion_histogram.png",
        "beltrami_histogram.png",
    }
    png = api.client.get(names["angle_distortion_histogram.png"]["url"])
    assert png.headers["content-type"] == "image/png"
    assert Image.open(io.BytesIO(png.content)).size == (640, 360)
    r = api.client.get(names["disk_map.npz"]["url"])
    assert r.status_code == 200 and r.headers["etag"] == f'"{names["disk_map.npz"]["etag"]}"'
    with np.load(io.BytesIO(r.content)) as z:
        uv, faces = z["uv"], z["faces"]
    V, F = read_mesh(small_face_path)
    assert uv.shape == (V.shape[0], 2) and np.array_equal(faces, F)
    assert np.max(np.linalg.norm(uv, axis=1)) <= 1 + 1e-9
    q = api.client.get(names["quality.json"]["url"])
    assert q.headers["content-type"].startswith("application/json")
    assert q.json()["flipped"] == 0 and q.json()["angle_distortion_mean"] < 5.0
    assert q.json()["info"]["extra"]["angle_refinement"]["step"] > 0
    # refine_angles=false: the harmonic map itself, with more angle distortion
    plain = _submit(api, "/v1/conformal-maps", {"mesh": mid, "refine_angles": False})
    api.run_job(str(plain["id"]))
    qp = api.client.get(f"/v1/jobs/{plain['id']}/artifacts/quality.json").json()
    assert "angle_refinement" not in qp["info"]["extra"]
    assert qp["angle_distortion_mean"] > q.json()["angle_distortion_mean"]


def test_reconstruction_job_end_to_end(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    job = _submit(api, "/v1/reconstructions", {"mesh": mid})
    assert [o.status for o in api.run_job(str(job["id"]))] == ["ran", "ran", "ran"]
    got = api.client.get(f"/v1/jobs/{job['id']}").json()
    assert got["state"] == "succeeded", got
    assert [s["name"] for s in got["stages"]] == ["conformal_map", "curvature", "reconstruct"]
    r = api.client.get(f"/v1/jobs/{job['id']}/artifacts/reconstruction.obj")
    assert r.headers["content-type"].startswith("model/obj")
    X, F = read_mesh(r.content, "obj")
    V, F0 = read_mesh(small_face_path)
    assert X.shape == V.shape and np.array_equal(F, F0)
    err = api.client.get(f"/v1/jobs/{job['id']}/artifacts/errors.json").json()["relative_error"]
    assert err["L2"] < 5e-3
    # the reconstruction is the surface, in the input's vertex order
    diag = np.linalg.norm(V.max(0) - V.min(0))
    assert np.median(np.linalg.norm(X - V, axis=1)) < 1e-2 * diag


def test_artifact_etag_and_ranges(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    job = _submit(api, "/v1/conformal-maps", {"mesh": mid})
    api.run_job(str(job["id"]))
    url = f"/v1/jobs/{job['id']}/artifacts/quality.json"
    full = api.client.get(url)
    etag = full.headers["etag"]
    assert api.client.get(url, headers={"If-None-Match": etag}).status_code == 304
    r = api.client.get(url, headers={"Range": "bytes=0-9"})
    assert r.status_code == 206 and r.content == full.content[:10]
    assert r.headers["content-range"] == f"bytes 0-9/{len(full.content)}"
    r = api.client.get(url, headers={"Range": "bytes=-5"})
    assert r.status_code == 206 and r.content == full.content[-5:]
    r = api.client.get(url, headers={"Range": "bytes=5-"})
    assert r.content == full.content[5:]
    r = api.client.get(url, headers={"Range": f"bytes={len(full.content)}-"})
    assert r.status_code == 416 and _error(r)["type"] == "range_not_satisfiable"
    r = api.client.get(f"/v1/jobs/{job['id']}/artifacts/nope.glb")
    assert r.status_code == 404 and _error(r)["field"] == "name"


def test_artifact_head_sends_gets_headers_without_a_body(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    job = _submit(api, "/v1/conformal-maps", {"mesh": mid})
    api.run_job(str(job["id"]))
    url = f"/v1/jobs/{job['id']}/artifacts/angle_distortion_histogram.png"
    same = ("content-type", "content-length", "etag", "accept-ranges", "cache-control")
    for headers, status in (
        ({}, 200),
        ({"Range": "bytes=3-9"}, 206),
        ({"If-None-Match": '"nope"'}, 200),
    ):
        got, head = api.client.get(url, headers=headers), api.client.head(url, headers=headers)
        assert got.status_code == head.status_code == status
        assert head.content == b"" and len(got.content) == int(got.headers["content-length"])
        for h in (*same, "content-range"):
            assert head.headers.get(h) == got.headers.get(h), h
    assert int(api.client.head(url).headers["content-length"]) > 1000
    etag = api.client.head(url).headers["etag"]
    assert api.client.head(url, headers={"If-None-Match": etag}).status_code == 304
    r = api.client.head(url, headers={"Range": "bytes=999999-"})
    assert r.status_code == 416 and r.headers["content-range"].startswith("bytes */")
    assert api.client.head(f"/v1/jobs/{job['id']}/artifacts/nope.glb").status_code == 404
    _, key = api.store.create_key("other")
    r = api.client.head(url, headers={"Authorization": f"Bearer {key}"})
    assert r.status_code == 404


def test_numerical_failure_ends_job_failed_with_reason(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    V, F = read_mesh(small_face_path)
    from conformorph.geometry import boundary_loop

    b0 = int(boundary_loop(F)[0])
    job = _submit(api, "/v1/conformal-maps", {"mesh": mid, "center_vertex": b0})
    assert [o.status for o in api.run_job(str(job["id"]))] == ["failed"]
    got = api.client.get(f"/v1/jobs/{job['id']}").json()
    assert got["state"] == "failed" and got["artifacts"] == []
    assert got["error"]["stage"] == "conformal_map"
    assert "boundary" in got["error"]["message"]


def test_submit_validation_errors(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    r = api.client.post("/v1/conformal-maps", json={"mesh": "0" * 32})
    assert r.status_code == 404 and _error(r)["field"] == "mesh"
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid, "center_vertex": 10_000})
    assert r.status_code == 422 and _error(r)["field"] == "center_vertex"
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid, "method": "magic"})
    assert r.status_code == 422 and _error(r)["field"] == "method"
    r = api.client.post("/v1/reconstructions", json={"mesh": mid, "extra": 1})
    assert r.status_code == 422 and _error(r)["field"] == "extra"
    r = api.client.post(
        "/v1/reconstructions", content=b"{not json", headers={"content-type": "application/json"}
    )
    assert r.status_code == 422
    _error(r)
    assert api.tasks.submitted == []


def test_list_jobs_paging_and_state_filter(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    ids = [
        _submit(api, "/v1/conformal-maps", {"mesh": mid, "method": m})["id"]
        for m in ("fast", "qiem")
    ]
    api.run_job(str(ids[0]))
    page = api.client.get("/v1/jobs", params={"limit": 1}).json()
    assert page["total"] == 2 and len(page["items"]) == 1 and page["items"][0]["id"] == ids[1]
    page2 = api.client.get("/v1/jobs", params={"limit": 1, "offset": 1}).json()
    assert page2["items"][0]["id"] == ids[0]
    done = api.client.get("/v1/jobs", params={"state": "succeeded"}).json()
    assert [j["id"] for j in done["items"]] == [ids[0]]
    assert api.client.get("/v1/jobs", params={"state": "bogus"}).status_code == 422


def test_cancel_queued_job_and_delete_finished_job(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    queued = _submit(api, "/v1/reconstructions", {"mesh": mid})
    r = api.client.delete(f"/v1/jobs/{queued['id']}")
    assert r.status_code == 200 and r.json()["state"] == "cancelled"
    # a worker that picks the message up afterwards drops it
    assert [o.status for o in api.run_job(str(queued["id"]))] == ["gone"]
    assert api.client.get(f"/v1/jobs/{queued['id']}").json()["artifacts"] == []
    done = _submit(api, "/v1/conformal-maps", {"mesh": mid})
    api.run_job(str(done["id"]))
    key = api.store.get_job(str(done["id"])).artifacts["disk_map.npz"]["key"]  # type: ignore[union-attr]
    assert api.storage.exists(key)
    assert api.client.delete(f"/v1/jobs/{done['id']}").status_code == 204
    assert not api.storage.exists(key)
    assert api.client.get(f"/v1/jobs/{done['id']}").status_code == 404
    assert api.client.delete(f"/v1/jobs/{done['id']}").status_code == 404


def test_idempotency_key(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    first = _submit(api, "/v1/conformal-maps", {"mesh": mid}, **{"Idempotency-Key": "abc"})
    r = api.client.post(
        "/v1/conformal-maps", json={"mesh": mid}, headers={"Idempotency-Key": "abc"}
    )
    assert r.status_code == 200 and r.json()["id"] == first["id"]
    assert len(api.tasks.submitted) == 1
    r = api.client.post(
        "/v1/conformal-maps",
        json={"mesh": mid, "method": "qiem"},
        headers={"Idempotency-Key": "abc"},
    )
    assert r.status_code == 409 and _error(r)["type"] == "idempotency_conflict"


def test_a_failed_enqueue_leaves_the_idempotency_key_free(
    api: Api, small_face_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    mid = _upload_ok(api, small_face_path)
    key = {"Idempotency-Key": "retry-me"}

    def refuse(job_id: str, stages: list[str]) -> None:
        raise ConnectionError("broker down")

    monkeypatch.setattr(api.tasks, "submit_job", refuse)
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid}, headers=key)
    assert r.status_code == 503 and _error(r)["type"] == "broker_unavailable", r.text
    assert r.headers["retry-after"] == "5"
    (lost,) = api.client.get("/v1/jobs").json()["items"]
    assert lost["state"] == "failed" and lost["error"]["type"] == "broker_unavailable"
    monkeypatch.undo()
    # the retry with the same key is a new job, and it is sent to the workers
    retry = _submit(api, "/v1/conformal-maps", {"mesh": mid}, **key)
    assert retry["id"] != lost["id"] and retry["state"] == "queued"
    assert api.tasks.submitted == [(retry["id"], ["conformal_map"])]
    # ... and from then on the key means that job
    again = api.client.post("/v1/conformal-maps", json={"mesh": mid}, headers=key)
    assert again.status_code == 200 and again.json()["id"] == retry["id"]
    assert len(api.tasks.submitted) == 1
    assert api.client.get(f"/v1/jobs/{lost['id']}").json()["state"] == "failed"


def test_active_job_limit(make_api: object, small_face_path: Path) -> None:
    api: Api = make_api(max_active_jobs=2)  # type: ignore[operator]
    mid = _upload_ok(api, small_face_path)
    a = _submit(api, "/v1/conformal-maps", {"mesh": mid})
    _submit(api, "/v1/conformal-maps", {"mesh": mid, "method": "qiem"})
    r = api.client.post("/v1/reconstructions", json={"mesh": mid})
    assert r.status_code == 429 and _error(r)["type"] == "too_many_jobs"
    api.run_job(str(a["id"]))
    assert api.client.post("/v1/reconstructions", json={"mesh": mid}).status_code == 202


def test_keys_isolation_and_401(api: Api, small_face_path: Path) -> None:
    _, key_a = api.store.create_key("alice")
    _, key_b = api.store.create_key("bob")
    ha, hb = {"Authorization": f"Bearer {key_a}"}, {"Authorization": f"Bearer {key_b}"}
    r = api.upload(small_face_path)
    assert r.status_code == 401 and _error(r)["type"] == "unauthorized"
    assert r.headers["www-authenticate"] == "Bearer"
    assert api.client.get("/v1/jobs", headers={"Authorization": "Bearer nope"}).status_code == 401
    assert (
        api.client.get("/v1/jobs", headers={"Authorization": f"Basic {key_a}"}).status_code == 401
    )
    mid = api.upload(small_face_path, headers=ha).json()["id"]
    job = _submit(api, "/v1/conformal-maps", {"mesh": mid}, **ha)
    api.run_job(str(job["id"]))
    jid = job["id"]
    assert api.client.get(f"/v1/jobs/{jid}", headers=ha).status_code == 200
    for url in (f"/v1/meshes/{mid}", f"/v1/jobs/{jid}", f"/v1/jobs/{jid}/artifacts/quality.json"):
        assert api.client.get(url, headers=hb).status_code == 404, url
    assert api.client.delete(f"/v1/jobs/{jid}", headers=hb).status_code == 404
    assert api.client.post("/v1/conformal-maps", json={"mesh": mid}, headers=hb).status_code == 404
    assert api.client.get("/v1/jobs", headers=hb).json()["total"] == 0
    # bob uploading the same bytes gets his own record
    rb = api.upload(small_face_path, headers=hb)
    assert rb.status_code == 201
    assert api.client.get("/healthz").status_code == 200  # health needs no key


def test_events_stream_ends_with_final_state(api: Api, small_face_path: Path) -> None:
    mid = _upload_ok(api, small_face_path)
    job = _submit(api, "/v1/conformal-maps", {"mesh": mid})
    api.run_job(str(job["id"]))
    with api.client.stream("GET", f"/v1/jobs/{job['id']}/events") as r:
        assert r.headers["content-type"].startswith("text/event-stream")
        text = "".join(r.iter_text())
    events = [blk for blk in text.split("\n\n") if blk.startswith("event:")]
    assert events[-1].startswith("event: end")
    state = json.loads(events[0].split("data: ", 1)[1])
    assert state["state"] == "succeeded" and state["progress"] == 1.0
    assert api.client.get("/v1/jobs/nope/events").status_code == 404


def test_textures(make_api: object) -> None:
    api: Api = make_api(max_texture_pixels=64 * 64)  # type: ignore[operator]
    buf = io.BytesIO()
    Image.new("RGB", (32, 16), (200, 10, 10)).save(buf, "PNG")
    r = api.client.post("/v1/textures", files={"file": ("skin.png", buf.getvalue())})
    assert r.status_code == 201, r.text
    assert (r.json()["width"], r.json()["height"], r.json()["content_type"]) == (
        32,
        16,
        "image/png",
    )
    assert api.client.get(f"/v1/textures/{r.json()['id']}").status_code == 200
    r = api.client.post("/v1/textures", files={"file": ("x.png", b"\x89PNG not really")})
    assert r.status_code == 422 and _error(r)["type"] == "invalid_image"
    big = io.BytesIO()
    Image.new("L", (100, 100)).save(big, "JPEG")
    r = api.client.post("/v1/textures", files={"file": ("big.jpg", big.getvalue())})
    assert r.status_code == 422 and _error(r)["type"] == "image_too_large"
    gif = io.BytesIO()
    Image.new("P", (4, 4)).save(gif, "GIF")
    r = api.client.post("/v1/textures", files={"file": ("a.gif", gif.getvalue())})
    assert r.status_code == 422 and _error(r)["type"] == "unsupported_image"


def test_unknown_routes_and_methods_are_json(api: Api) -> None:
    r = api.client.get("/v1/nothing")
    assert r.status_code == 404 and _error(r)["type"] == "not_found"
    r = api.client.put("/v1/jobs")
    assert r.status_code == 405 and _error(r)["type"] == "method_not_allowed"


def test_service_imports_neither_geometry_nor_task_bodies(tmp_path: Path) -> None:
    # a fresh interpreter: importing and building the app loads no numerics at all
    code = (
        "import sys, conformorph.service.main, conformorph.service.task_client;"
        "from conformorph.service.core.config import Settings;"
        f"conformorph.service.main.create_app(Settings(data_dir={str(tmp_path)!r})).openapi();"
        "heavy = ('numpy', 'scipy', 'geometry', 'trimesh', 'shapely', 'triangle');"
        "bad = [m for m in sys.modules if m.removeprefix('conformorph.').split('.')[0] in heavy"
        " or m in ('conformorph.worker.tasks', 'conformorph.worker.stages', 'conformorph.pipelines.landmarks_io')];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=Path(__file__).parents[2]
    )
    assert out.returncode == 0, out.stdout + out.stderr


def test_open_mode_serves_loopback_clients_only(api: Api) -> None:
    remote = TestClient(api.app, client=("203.0.113.7", 5000))
    r = remote.get("/v1/jobs")
    assert r.status_code == 403 and "loopback" in str(_error(r)["message"])
    local = TestClient(api.app, client=("127.0.0.1", 5000))
    assert local.get("/v1/jobs").status_code == 200
    _, key = api.store.create_key("remote-user")
    assert remote.get("/v1/jobs", headers={"Authorization": f"Bearer {key}"}).status_code == 200


def test_first_key_is_enforced_within_the_recheck_time(
    make_api: object, small_face_path: Path
) -> None:
    api: Api = make_api(open_mode_recheck_seconds=0.3)  # type: ignore[operator]
    assert api.client.get("/v1/jobs").status_code == 200  # open
    api.store.create_key("first")
    import time

    time.sleep(0.35)
    r = api.client.get("/v1/jobs")
    assert r.status_code == 401 and _error(r)["type"] == "unauthorized"


def test_405_lists_every_allowed_method_and_bad_bodies_are_400(api: Api) -> None:
    r = api.client.options("/v1/jobs/abc")
    assert r.status_code == 405 and r.headers["allow"] == "DELETE, GET"
    r = api.client.post(
        "/v1/conformal-maps", content=b"\xff\xfe{", headers={"content-type": "application/json"}
    )
    assert r.status_code in (400, 422)
    _error(r)
