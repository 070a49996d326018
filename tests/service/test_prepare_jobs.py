"""``"prepare": "auto"`` over HTTP: uploads report what it changes, jobs ask for it."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from conformorph.pipelines.mesh_io import write_obj
from tests.fixtures.make_service_small_face import small_face
from tests.service.conftest import Api


def _scan_like(tmp_path: Path) -> tuple[Path, Path, int]:
    """The small face with a floating fragment and a duplicate face, and the clean face."""
    V, F = small_face(10)
    n = V.shape[0]
    frag = np.array([[300.0, 0, 0], [310, 0, 0], [300, 10, 0]])
    V2 = np.vstack([V, frag])
    F2 = np.vstack([F, [[n, n + 1, n + 2]], F[:1]])
    bad, clean = tmp_path / "scan.obj", tmp_path / "clean.obj"
    write_obj(bad, V2, F2)
    write_obj(clean, V, F)
    return bad, clean, n


def test_upload_reports_preparation_and_jobs_need_auto(api: Api, tmp_path: Path) -> None:
    bad, clean, n = _scan_like(tmp_path)
    r = api.client.post("/v1/meshes", files={"file": (bad.name, bad.read_bytes())})
    assert r.status_code == 201, r.text
    report = r.json()["report"]
    prep = report["preparation_needed"]
    assert prep["dropped_components"] == [{"vertices": 3, "faces": 1}]
    assert prep["duplicate_faces"] == 1 and prep["vertices"] == n
    assert "repairs_needed" not in report and report["n_vertices"] == n + 3
    mid = r.json()["id"]
    r = api.client.post("/v1/meshes", files={"file": (clean.name, clean.read_bytes())})
    assert "preparation_needed" not in r.json()["report"]
    for route in ("/v1/conformal-maps", "/v1/reconstructions"):
        r = api.client.post(route, json={"mesh": mid})
        assert r.status_code == 422, r.text
        err = r.json()["error"]
        assert err["type"] == "mesh_needs_preparation" and err["field"] == "mesh"
        assert '"prepare": "auto"' in err["message"]
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid, "prepare": "auto"})
    assert r.status_code == 202, r.text
    assert r.json()["params"]["prepare"] == "auto"
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    art = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/disk_map.npz").content
    with np.load(io.BytesIO(art)) as z:
        uv, vmap = z["uv"], z["vertex_map"]
    np.testing.assert_array_equal(vmap, np.arange(n))  # the fragment's rows dropped
    assert uv.shape == (n, 2) and np.abs(np.linalg.norm(uv, axis=1)).max() <= 1 + 1e-9
    q = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/quality.json").json()
    assert q["preparation"]["dropped_components"] == [{"vertices": 3, "faces": 1}]


def test_prepare_field_is_validated(api: Api, tmp_path: Path) -> None:
    _, clean, _ = _scan_like(tmp_path)
    r = api.client.post("/v1/meshes", files={"file": (clean.name, clean.read_bytes())})
    r = api.client.post("/v1/conformal-maps", json={"mesh": r.json()["id"], "prepare": "yes"})
    assert r.status_code == 422 and "prepare" in r.text


def test_morph_job_with_prepare_auto(api: Api, tmp_path: Path) -> None:
    bad, clean, n = _scan_like(tmp_path)
    ids = []
    for p in (bad, clean):
        r = api.client.post("/v1/meshes", files={"file": (p.name, p.read_bytes())})
        ids.append(r.json()["id"])
    lm = [0, 40, 80, 120, 160, 200]
    body = {"meshes": ids, "landmarks": [lm, lm], "frames": 3}
    r = api.client.post("/v1/morphs", json={**body, "prepare": "none"})
    assert r.status_code == 422 and r.json()["error"]["type"] == "mesh_needs_preparation"
    # the morph's default is the CLI's, prepare auto (issue 27)
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 202 and r.json()["params"]["prepare"] == "auto", r.text
    r = api.client.post("/v1/morphs", json={**body, "prepare": "auto"})
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    outs = api.run_job(jid)
    assert all(o.status == "ran" for o in outs), outs[-1].job
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    prep = [m["preparation"] for m in metrics["inputs"]]
    assert prep[0]["removed_vertices"] == 3 and prep[1]["unchanged"]


def test_closed_head_upload_is_cut_to_its_face_with_auto(api: Api) -> None:
    from tests.meshes import FIXTURES

    head = FIXTURES / "closed_head.obj"
    r = api.client.post("/v1/meshes", files={"file": (head.name, head.read_bytes())})
    assert r.status_code == 201, r.text
    prep = r.json()["report"]["preparation_needed"]
    assert prep["face_cut"]["reason"] == "closed" and prep["faces"] < 528
    mid = r.json()["id"]
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid})
    assert r.status_code == 422 and r.json()["error"]["type"] == "mesh_needs_preparation"
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid, "prepare": "auto"})
    assert r.status_code == 202, r.text
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    art = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/disk_map.npz").content
    with np.load(io.BytesIO(art)) as z:
        uv, vmap = z["uv"], z["vertex_map"]
    assert uv.shape == (prep["vertices"], 2) and vmap.size == prep["vertices"]
    assert np.abs(np.linalg.norm(uv, axis=1)).max() <= 1 + 1e-9


def test_vertex_budget_field_decimates_a_job(api: Api, tmp_path: Path) -> None:
    V, F = small_face(30)  # 2,791 vertices
    path = tmp_path / "dense.obj"
    write_obj(path, V, F)
    mid = api.client.post("/v1/meshes", files={"file": (path.name, path.read_bytes())}).json()
    for bad in (500, -1, "many"):
        r = api.client.post(
            "/v1/conformal-maps", json={"mesh": mid["id"], "prepare": "auto", "vertex_budget": bad}
        )
        assert r.status_code == 422 and "vertex_budget" in r.text, r.text
    body = {"mesh": mid["id"], "prepare": "auto", "vertex_budget": 1000}
    r = api.client.post("/v1/conformal-maps", json=body)
    assert r.status_code == 202, r.text
    assert r.json()["params"]["vertex_budget"] == 1000
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    art = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/disk_map.npz").content
    with np.load(io.BytesIO(art)) as z:
        uv, vmap = z["uv"], z["vertex_map"]
    assert uv.shape[0] == vmap.shape[0] < 1100 and vmap.max() < V.shape[0]
    q = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/quality.json").json()
    assert q["preparation"]["decimation"]["vertex_budget"] == 1000
    # 0: never decimate, the mesh left as read
    r = api.client.post("/v1/conformal-maps", json={**body, "vertex_budget": 0})
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    q = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/quality.json").json()
    assert q["preparation"]["decimation"] is None and q["preparation"]["unchanged"]
