"""Face morphs and 2D morphs through the API, stages run in-process (real pipelines)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.mesh_io import write_obj
from tests.fixtures.make_service_small_face import small_face, with_hole_and_ear
from tests.service.conftest import Api

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"


@pytest.fixture
def face_pair(tmp_path: Path) -> tuple[Path, Path, list[int]]:
    """Two small faces with the same connectivity, the second one deformed; 9 landmarks."""
    V, F = small_face(10)
    W = V.copy()
    W[:, 2] += 3.0 * np.sin(V[:, 0] / 30.0)
    W[:, 1] *= 1.05
    a, b = tmp_path / "face_a.obj", tmp_path / "face_b.obj"
    write_obj(a, V, F)
    write_obj(b, W, F)
    r = np.linalg.norm(V[:, :2] / np.array([80.0, 100.0]), axis=1)
    ring = np.flatnonzero(np.abs(r - 0.5) < 0.02)
    landmarks = [0, *[int(i) for i in ring[:: max(1, ring.size // 8)][:8]]]
    return a, b, landmarks


def _upload(api: Api, path: Path, route: str = "/v1/meshes") -> str:
    r = api.client.post(route, files={"file": (path.name, path.read_bytes())})
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def _needs_face_pipeline() -> None:
    pytest.importorskip("conformorph.pipelines.face_morph")
    pytest.importorskip("conformorph.pipelines.landmarks_io")


def test_face_morph_job(api: Api, face_pair: tuple[Path, Path, list[int]]) -> None:
    _needs_face_pipeline()
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    r = api.client.post(
        "/v1/morphs", json={"meshes": ids, "landmarks": [lm, lm], "frames": 5, "per_frame": True}
    )
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    assert [s["name"] for s in r.json()["stages"]] == [
        "prepare",
        "register",
        "frames",
        "export",
        "metrics",
    ]
    outs = api.run_job(jid)
    assert [o.status for o in outs] == ["ran"] * 5, outs[-1].job
    job = api.client.get(f"/v1/jobs/{jid}").json()
    assert job["state"] == "succeeded"
    names = {x["name"]: x for x in job["artifacts"]}
    assert set(names) == {
        "animation.glb",
        "metrics.json",
        *(f"frames/{k:03d}.glb" for k in range(5)),
    }
    glb = api.client.get(f"/v1/jobs/{jid}/artifacts/animation.glb")
    assert glb.headers["content-type"] == "model/gltf-binary" and glb.content[:4] == b"glTF"
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert len(metrics["frame_times"]) == 5 and metrics["inputs"][1]["mesh"] == ids[1]
    assert set(metrics["seconds"]) == {"prepare", "register", "frames", "export"}
    assert set(metrics["files"]) == {"animation.glb", *(f"frames/{k:03d}.glb" for k in range(5))}
    assert len(metrics["frames"]["key_frame_L2_to_inputs"]["dmt"]) == 2
    # the MT baseline only on request (job field baselines, default off as the CLI's)
    assert "mt" not in metrics["frames"]["key_frame_L2_to_inputs"]
    assert "baselines" in metrics["skipped"]["mt_baseline"]
    # units inferred from the faces' size (160 mm across), the GLB in metres, named
    units = metrics["units"]
    assert units["declared"] == "auto" and units["working_unit"] == "mm"
    assert [(k["units"], k["source"]) for k in units["keys"]] == [("mm", "size")] * 2
    import pygltflib

    gl = pygltflib.GLTF2.load_from_bytes(glb.content)
    assert gl.nodes[0].name == "face_a_to_face_b" and gl.nodes[0].extras["units"] == "m"
    assert gl.nodes[0].translation is None and gl.nodes[0].scale is None
    # intermediate stage results are not served
    assert api.client.get(f"/v1/jobs/{jid}/artifacts/registration.npz").status_code == 404


def test_face_morph_job_builds_the_baseline_on_request(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    """``"baselines": true`` reaches the worker: the MT baseline is built and measured."""
    _needs_face_pipeline()
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    body = {"meshes": ids, "landmarks": [lm, lm], "frames": 3, "baselines": True}
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    assert api.client.get(f"/v1/jobs/{jid}/params").json()["baselines"] is True
    assert [o.status for o in api.run_job(jid)] == ["ran"] * 5
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert set(metrics["frames"]["key_frame_L2_to_inputs"]) == {"dmt", "mt", "linear"}
    assert "mt_baseline" not in metrics["skipped"]


def test_face_morph_request_errors(
    make_api: object, face_pair: tuple[Path, Path, list[int]]
) -> None:
    api: Api = make_api(max_key_frames=2, max_frames=30)  # type: ignore[operator]
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    cases = [
        ({"meshes": ids, "landmarks": [lm]}, 422, "landmarks"),
        ({"meshes": ids, "landmarks": [lm, lm[:-1]]}, 422, "landmarks"),
        ({"meshes": ids, "landmarks": [lm[:2], lm[:2]]}, 422, "landmarks"),
        ({"meshes": ids, "landmarks": [lm, lm], "frames": 31}, 422, "frames"),
        ({"meshes": [*ids, ids[0]], "landmarks": [lm, lm, lm]}, 422, "meshes"),
        ({"meshes": ids, "landmarks": [lm, lm], "times": [0, 0]}, 422, "times"),
        ({"meshes": ids, "landmarks": [lm, lm], "landmark_fit": "loose"}, 422, "landmark_fit"),
        ({"meshes": [ids[0], "f" * 32], "landmarks": [lm, lm]}, 404, "meshes[1]"),
        (
            {"meshes": ids, "landmarks": [lm, lm], "textures": ["0" * 32, "1" * 32]},
            404,
            "textures[0]",
        ),
        # not an id this service makes: refused before any look-up
        ({"meshes": ids, "landmarks": [lm, lm], "textures": ["x", "y"]}, 422, "textures[0]"),
        ({"meshes": [ids[0], "\u0000"], "landmarks": [lm, lm]}, 422, "meshes[1]"),
        ({"meshes": ids, "landmarks": [lm, lm], "method": "warp"}, 422, "method"),
        ({"meshes": ids, "landmarks": [[0, 1, [1.0, 2.0]], [0, 1, 2]]}, 422, "landmarks[0][2]"),
        (
            {"meshes": ids, "landmarks": [lm, lm], "frame_times": [0, 0.5, 0.5]},
            422,
            "frame_times[2]",
        ),
        ({"meshes": ids, "landmarks": [lm, lm], "frame_times": []}, 422, "frame_times"),
        (
            {"meshes": ids, "landmarks": [lm, lm], "frame_times": [0, 1], "frames": 2},
            422,
            "frame_times",
        ),
        ({"meshes": ids, "landmarks": [lm, lm], "frame_times": list(range(31))}, 422, "frames"),
        ({"meshes": ids, "landmarks": [lm, lm], "refine": "icp"}, 422, "refine"),
    ]
    for body, status, field in cases:
        r = api.client.post("/v1/morphs", json=body)
        assert r.status_code == status, (body, r.text)
        assert r.json()["error"]["field"] == field, (body, r.json())
    assert api.tasks.submitted == []


def test_face_morph_units_mismatch_fails_the_job_and_bad_units_are_refused(
    api: Api, face_pair: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    _needs_face_pipeline()
    from conformorph.pipelines.mesh_io import read_mesh

    a, b, lm = face_pair
    V, F = read_mesh(b)
    big = tmp_path / "face_b_x10.obj"
    write_obj(big, 10.0 * V, F)
    ids = [_upload(api, a), _upload(api, big)]
    body = {"meshes": ids, "landmarks": [lm, lm], "frames": 3}
    r = api.client.post("/v1/morphs", json={**body, "units": "inch"})
    assert r.status_code == 422 and r.json()["error"]["field"] == "units", r.text
    r = api.client.post("/v1/morphs", json={**body, "units": "mm"})  # declared: 10x apart
    jid = r.json()["id"]
    assert [o.status for o in api.run_job(jid)] == ["failed"]
    err = api.client.get(f"/v1/jobs/{jid}").json()["error"]
    assert err["stage"] == "prepare" and "sizes disagree" in err["message"], err


def test_face_morph_bad_landmark_fails_the_job_naming_the_input(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    _needs_face_pipeline()
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    bad = [*lm[:-1], 100_000]
    r = api.client.post("/v1/morphs", json={"meshes": ids, "landmarks": [lm, bad], "frames": 3})
    jid = r.json()["id"]
    assert [o.status for o in api.run_job(jid)] == ["failed"]
    err = api.client.get(f"/v1/jobs/{jid}").json()["error"]
    assert err["stage"] == "prepare" and err["field"] == "landmarks[1]"
    assert "100000" in err["message"]


def test_morph2d_job(api: Api) -> None:
    src = _upload(api, SHAPES / "bar_straight.json", "/v1/shapes")
    dst = _upload(api, SHAPES / "bar_bent.json", "/v1/shapes")
    shape = api.client.get(f"/v1/shapes/{src}").json()
    assert shape["rings"] >= 1 and shape["points"] >= 3
    anchors = json.loads((SHAPES / "bar_anchors.json").read_text())["anchors"]
    r = api.client.post(
        "/v1/morphs2d", json={"source": src, "target": dst, "anchors": anchors, "frames": 4}
    )
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    assert [o.status for o in api.run_job(jid)] == ["ran"]
    job = api.client.get(f"/v1/jobs/{jid}").json()
    names = {x["name"] for x in job["artifacts"]}
    assert {"animation.glb", "metrics.json", "strip.svg", "animation.svg", "frames.json"} <= names
    web = api.client.get(f"/v1/jobs/{jid}/artifacts/animation.svg")
    assert web.headers["content-type"].startswith("image/svg+xml")
    frames = api.client.get(f"/v1/jobs/{jid}/artifacts/frames.json")
    assert frames.headers["content-type"].startswith("application/json")
    assert len(frames.json()["frames"]) == 4
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert metrics["source"] == src and metrics["frames"] == 4
    svg = api.client.get(f"/v1/jobs/{jid}/artifacts/strip.svg")
    assert svg.headers["content-type"].startswith("image/svg+xml")


def test_shape_upload_and_morph2d_errors(api: Api) -> None:
    r = api.client.post("/v1/shapes", files={"file": ("s.json", b'{"rings": []}')})
    assert r.status_code == 422 and r.json()["error"]["field"] == "file"
    r = api.client.post("/v1/shapes", files={"file": ("s.json", b"{not json")})
    assert r.status_code == 422
    r = api.client.post("/v1/shapes", files={"file": ("s.png", io.BytesIO(b"x").getvalue())})
    assert r.status_code == 422 and r.json()["error"]["type"] == "unsupported_file_type"
    src = _upload(api, SHAPES / "bar_straight.json", "/v1/shapes")
    r = api.client.post(
        "/v1/morphs2d", json={"source": src, "target": "0" * 32, "anchors": [[[0, 0], [0, 0]]] * 2}
    )
    assert r.status_code == 404 and r.json()["error"]["field"] == "target"
    r = api.client.post(
        "/v1/morphs2d", json={"source": src, "target": src, "anchors": [[[0, 0]], [[1, 1], [2, 2]]]}
    )
    assert r.status_code == 422 and r.json()["error"]["field"] == "anchors[0]"
    # one pair is accepted since issue 18 (it seeds the automatic matching); more than
    # 1000 are not
    r = api.client.post(
        "/v1/morphs2d", json={"source": src, "target": src, "anchors": [[[0, 0], [0, 0]]] * 1001}
    )
    assert r.status_code == 422 and r.json()["error"]["field"] == "anchors"
    for field, bad in (("units", "furlong"), ("size", 0), ("size", -1.0)):
        r = api.client.post("/v1/morphs2d", json={"source": src, "target": src, field: bad})
        assert r.status_code == 422 and r.json()["error"]["field"] == field, r.text
    assert api.tasks.submitted == []


def test_landmark_sets_and_morph_by_landmarks_id(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    _needs_face_pipeline()
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    shared = api.client.post(
        "/v1/landmarks", json={"nearest_vertex_0based": lm, "note": "shared list"}
    )
    assert shared.status_code == 201, shared.text
    assert shared.json()["meshes"] is None and shared.json()["landmarks_per_mesh"] == len(lm)
    again = api.client.post(
        "/v1/landmarks", json={"note": "shared list", "nearest_vertex_0based": lm}
    )
    assert again.status_code == 200 and again.json()["id"] == shared.json()["id"]
    per_mesh = api.client.post("/v1/landmarks", json={"landmarks": [lm, lm]})
    assert per_mesh.status_code == 201 and per_mesh.json()["meshes"] == 2
    assert api.client.get(f"/v1/landmarks/{shared.json()['id']}").json()[
        "landmarks_per_mesh"
    ] == len(lm)
    r = api.client.post(
        "/v1/morphs", json={"meshes": ids, "landmarks_id": shared.json()["id"], "frames": 3}
    )
    assert r.status_code == 202, r.text
    assert api.store.get_job(r.json()["id"]).params["landmarks"] == [lm, lm]  # type: ignore[union-attr]
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"] * 5


def test_landmark_set_errors(api: Api, face_pair: tuple[Path, Path, list[int]]) -> None:
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    for doc in ({"foo": 1}, {"landmarks": [[0, 1, 2], [0, 1]]}, {"landmarks": [[0, 1], [0, 1]]}):
        r = api.client.post("/v1/landmarks", json=doc)
        assert r.status_code == 422 and r.json()["error"]["field"] == "landmarks", r.text
    assert api.client.post("/v1/landmarks", json=[1, 2]).status_code == 422
    three = api.client.post("/v1/landmarks", json={"landmarks": [lm, lm, lm]}).json()["id"]
    r = api.client.post("/v1/morphs", json={"meshes": ids, "landmarks_id": three})
    assert r.status_code == 422 and "3 lists" in r.json()["error"]["message"]
    r = api.client.post("/v1/morphs", json={"meshes": ids, "landmarks_id": "0" * 32})
    assert r.status_code == 404 and r.json()["error"]["field"] == "landmarks_id"
    r = api.client.post(
        "/v1/morphs", json={"meshes": ids, "landmarks_id": three, "landmarks": [lm, lm]}
    )
    assert r.status_code == 422
    r = api.client.post("/v1/morphs", json={"meshes": ids})
    assert r.status_code == 422 and r.json()["error"]["field"] == "landmarks"
    _, key = api.store.create_key("other")
    r = api.client.get(f"/v1/landmarks/{three}", headers={"Authorization": f"Bearer {key}"})
    assert r.status_code == 404


@pytest.mark.parametrize(
    ("doc", "field"),
    [
        ({"landmarks": [[1.5, 2, 3], [1, 2, 3]]}, "landmarks[0][0]"),
        ({"landmarks": [[1, "x", 3], [1, 2, 3]]}, "landmarks[0][1]"),
        ({"nearest_vertex_0based": [1, 2, None, 4]}, "nearest_vertex_0based[2]"),
        ({"landmarks": [[1, 2, 3], [1, -2, 3]]}, "landmarks[1][1]"),
        ({"landmarks": [[1, 2, [0.0, 1.0]], [1, 2, 3]]}, "landmarks[0][2]"),
        (
            {"face1": {"interior_landmarks_0based": [1, 2, "3"]}},
            "face1.interior_landmarks_0based[2]",
        ),
    ],
)
def test_landmark_documents_are_checked_entry_by_entry(
    api: Api, face_pair: tuple[Path, Path, list[int]], doc: dict[str, object], field: str
) -> None:
    a, b, _ = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    r = api.client.post("/v1/landmarks", json=doc)
    assert r.status_code == 422, r.text
    assert r.json()["error"]["field"] == field and field in r.json()["error"]["message"]
    # a document stored before these checks existed (or by other means) is checked
    # again when a morph uses it: 422 naming the set and the entry, never a 500
    set_id = "a" * 32
    api.store.add_landmarks("open", set_id, doc)
    r = api.client.post("/v1/morphs", json={"meshes": ids, "landmarks_id": set_id})
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["field"] == "landmarks_id" and field in err["message"] and set_id in err["message"]
    assert api.tasks.submitted == []


def test_landmark_document_with_nan_is_refused(api: Api) -> None:
    # Python's JSON reader takes NaN/Infinity, which neither JSON nor PostgreSQL's json type does
    for body, field in (
        (b'{"landmarks": [[0, 1, 2], [0, 1, 2]], "note": {"x": [1, NaN]}}', "note.x[1]"),
        (b'{"landmarks": [[0, 1, [0, 0, Infinity]], [0, 1, 2]]}', "landmarks[0][2][2]"),
    ):
        r = api.client.post(
            "/v1/landmarks", content=body, headers={"content-type": "application/json"}
        )
        assert r.status_code == 422 and r.json()["error"]["field"] == field, r.text
    assert api.client.get("/v1/jobs").status_code == 200


def test_inline_and_stored_landmarks_give_the_same_job(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    # 4.0 is the vertex 4 (JSON has one number type); points are kept as floats
    lists = [[*lm[:-1], float(lm[-1])], [*lm[:-1], [1, 2, 3]]]
    set_id = api.client.post("/v1/landmarks", json={"landmarks": lists}).json()["id"]
    inline = api.client.post("/v1/morphs", json={"meshes": ids, "landmarks": lists})
    stored = api.client.post("/v1/morphs", json={"meshes": ids, "landmarks_id": set_id})
    assert inline.status_code == stored.status_code == 202, (inline.text, stored.text)
    want = [lm, [*lm[:-1], [1.0, 2.0, 3.0]]]
    for r in (inline, stored):
        got = api.store.get_job(r.json()["id"]).params["landmarks"]  # type: ignore[union-attr]
        assert got == want and isinstance(got[0][-1], int)


def test_face_morph_job_with_normals_and_fold_report(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    _needs_face_pipeline()
    import pygltflib

    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    body = {"meshes": ids, "landmarks": [lm, lm], "frames": 3}  # normals: on by default
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    outs = api.run_job(jid)
    assert [o.status for o in outs] == ["ran"] * 5, outs[-1].job
    glb = api.client.get(f"/v1/jobs/{jid}/artifacts/animation.glb").content
    prim = pygltflib.GLTF2.load_from_bytes(glb).meshes[0].primitives[0]
    assert prim.attributes.NORMAL is not None and prim.targets[0]["NORMAL"] is not None
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert metrics["bijectivity"]["folded_triangles"] == 0
    assert metrics["bijectivity"]["min_jacobian"] > 0
    bad = api.client.post("/v1/morphs", json={**body, "normals": "sometimes"})
    assert bad.status_code == 422


def test_textured_face_morph_job_serves_the_key_textures(
    api: Api, face_pair: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    _needs_face_pipeline()
    from PIL import Image

    from conformorph.pipelines.mesh_io import read_mesh

    a, b, lm = face_pair
    ids, tex = [], []
    for k, path in enumerate((a, b)):
        V, F = read_mesh(path)
        uv = 0.5 + 0.45 * V[:, :2] / np.abs(V[:, :2]).max(axis=0)
        lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in V]
        lines += [f"vt {u:.9g} {v:.9g}" for u, v in uv]
        lines += [f"f {i + 1}/{i + 1} {j + 1}/{j + 1} {m + 1}/{m + 1}" for i, j, m in F]
        obj = tmp_path / f"tex_{k}.obj"
        obj.write_text("\n".join(lines) + "\n")
        ids.append(_upload(api, obj))
        buf = io.BytesIO()
        Image.new("RGB", (16, 8), (200, 10, 10) if k == 0 else (10, 10, 200)).save(buf, "PNG")
        r = api.client.post("/v1/textures", files={"file": (f"t{k}.png", buf.getvalue())})
        assert r.status_code == 201, r.text
        tex.append(r.json()["id"])
    body = {"meshes": ids, "landmarks": [lm, lm], "frames": 3, "textures": tex, "per_frame": True}
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    outs = api.run_job(jid)
    assert [o.status for o in outs] == ["ran"] * 5, outs[-1].job
    names = {x["name"] for x in api.client.get(f"/v1/jobs/{jid}").json()["artifacts"]}
    assert {"textures/key_000.png", "textures/key_001.png", "frames/001.glb"} <= names
    png = api.client.get(f"/v1/jobs/{jid}/artifacts/textures/key_001.png")
    assert png.headers["content-type"] == "image/png"
    key1 = np.asarray(Image.open(io.BytesIO(png.content)))
    assert key1.shape == (8, 16, 3) and np.all(key1 == (10, 10, 200))
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert metrics["registration"]["appearance"]["source"] == "texture"


def test_face_morph_job_at_explicit_frame_times_with_a_refinement(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    """frame_times (some outside [t0, tN]: extrapolated, Table 4) and refine reach the worker."""
    _needs_face_pipeline()
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    ft = [-0.25, 0.0, 0.4, 1.0, 1.25]
    body = {"meshes": ids, "landmarks": [lm, lm], "frame_times": ft, "refine": "none"}
    body["landmark_fit"] = "tolerant"
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 202, r.text
    assert r.json()["params"]["frame_times"] == ft and r.json()["params"]["refine"] == "none"
    assert r.json()["params"]["landmark_fit"] == "tolerant"
    jid = r.json()["id"]
    outs = api.run_job(jid)
    assert [o.status for o in outs] == ["ran"] * 5, outs[-1].job
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert metrics["frame_times"] == ft
    # the paper's DMT (refine "none") takes no correspondences beyond the landmarks
    assert metrics["registration"]["refine"]["preset"] == "none"
    assert metrics["registration"]["landmark_fit"] == "tolerant"
    pair = metrics["registration"]["pairs"][0]
    assert pair["static_correspondences"] == [] and pair["nicp"] is None


def test_meshes_with_holes_or_ears_are_stored_and_morphed_with_the_repairs_they_need(
    api: Api, face_pair: tuple[Path, Path, list[int]], tmp_path: Path
) -> None:
    _needs_face_pipeline()
    from conformorph.pipelines.mesh_io import read_mesh

    a, b, lm = face_pair
    V, F = read_mesh(a)
    V2, F2, ear = with_hole_and_ear(V, F)
    bad = tmp_path / "holed_eared.obj"
    write_obj(bad, V2, F2)
    r = api.client.post("/v1/meshes", files={"file": (bad.name, bad.read_bytes())})
    assert r.status_code == 201, r.text
    needed = r.json()["report"]["repairs_needed"]
    assert needed == {"fill_holes": 1, "remove_ears": [ear]}
    mid, ok = r.json()["id"], _upload(api, a)
    # a job not asking for the repairs is refused at once, told what the mesh needs
    for route in ("/v1/conformal-maps", "/v1/reconstructions"):
        r = api.client.post(route, json={"mesh": mid, "remove_ears": True})
        assert r.status_code == 422, r.text
        err = r.json()["error"]
        assert err["type"] == "mesh_needs_repair" and err["field"] == "mesh"
        assert "1 hole(s)" in err["message"] and f"[{ear}]" in err["message"]
        assert "fill_holes: true" in err["message"] and "remove_ears" not in err["message"][-30:]
    # with them, as 'conformorph map/reconstruct --fill-holes --remove-ears': the outputs
    # keep every input vertex, in order (the ear back on the unit circle / at its position)
    repairs = {"fill_holes": True, "remove_ears": True}
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid, **repairs, "center_vertex": 5})
    assert r.status_code == 202, r.text
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"]
    with np.load(
        io.BytesIO(api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/disk_map.npz").content)
    ) as z:
        uv, faces, kept = z["uv"], z["faces"], z["kept"]
    assert uv.shape == (V2.shape[0], 2) and np.array_equal(faces, F2)
    assert np.flatnonzero(~kept).tolist() == [ear] and abs(np.linalg.norm(uv[ear]) - 1) < 1e-9
    assert np.linalg.norm(uv[5]) < 1e-9  # centre_vertex: an input id
    q = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/quality.json").json()
    assert q["filled_holes"] == 1 and q["removed_ear_vertex_ids"] == [ear] and q["flipped"] == 0
    r = api.client.post("/v1/reconstructions", json={"mesh": mid, **repairs})
    assert r.status_code == 202, r.text
    assert [o.status for o in api.run_job(r.json()["id"])] == ["ran"] * 3
    rec = r.json()["id"]
    X, FX = read_mesh(api.client.get(f"/v1/jobs/{rec}/artifacts/reconstruction.obj").content, "obj")
    assert np.array_equal(FX, F2) and np.allclose(X[ear], V2[ear])
    assert (
        api.client.get(f"/v1/jobs/{rec}/artifacts/errors.json").json()["relative_error"]["L2"]
        < 5e-3
    )
    with np.load(io.BytesIO(api.client.get(f"/v1/jobs/{rec}/artifacts/h_lambda.npz").content)) as z:
        assert z["lam"].shape == (V2.shape[0],) and np.isnan(z["lam"][ear])
    # a centre vertex that the repair removes is named
    r = api.client.post("/v1/conformal-maps", json={"mesh": mid, **repairs, "center_vertex": ear})
    assert [o.status for o in api.run_job(r.json()["id"])] == ["failed"]
    err = api.client.get(f"/v1/jobs/{r.json()['id']}").json()["error"]
    assert err["field"] == "center_vertex" and "ear" in err["message"]
    lm_b = [i - 1 for i in lm[1:]]  # its ids: vertex 0 (a landmark of a) is gone
    # prepare "none" (the morph's default is "auto", which grants every repair)
    body = {"meshes": [ok, mid], "landmarks": [lm[1:], lm_b], "frames": 3, "prepare": "none"}
    before = len(api.tasks.submitted)
    r = api.client.post("/v1/morphs", json={**body, "fill_holes": True})
    assert r.status_code == 422 and r.json()["error"]["field"] == "meshes[1]"
    assert "remove_ears: true" in r.json()["error"]["message"]
    assert len(api.tasks.submitted) == before
    r = api.client.post("/v1/morphs", json={**body, "fill_holes": True, "remove_ears": True})
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    outs = api.run_job(jid)
    assert [o.status for o in outs] == ["ran"] * 5, outs[-1].job
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    assert metrics["bijectivity"]["folded_triangles"] == 0
    # the hole's centre appended, the ear removed: as many vertices as before
    assert metrics["inputs"][1]["n_vertices"] == V2.shape[0]


def test_a_closed_surface_is_still_refused(api: Api) -> None:
    tetra = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n"
    r = api.client.post("/v1/meshes", files={"file": ("tetra.obj", tetra)})
    assert r.status_code == 422 and "disk" in r.json()["error"]["message"]


def test_landmark_sets_may_name_an_ibug_subset(api: Api) -> None:
    """Issue 27: "indices" (0-based ibug) is accepted and checked by the API."""
    five = [39, 42, 30, 48, 54]
    doc = {"landmarks": [[1, 2, 3, 4, 5], [6, 7, 8, 9, 10]], "indices": five}
    ok = api.client.post("/v1/landmarks", json=doc)
    assert ok.status_code == 201, ok.text
    bad = api.client.post("/v1/landmarks", json={**doc, "indices": [39, 42, 30, 48, 68]})
    assert bad.status_code == 422 and "ibug index" in bad.json()["error"]["message"], bad.text
    fill = api.client.post("/v1/landmarks", json={**doc, "indices": None, "fill": "auto"})
    assert fill.status_code == 422 and "needs" in fill.json()["error"]["message"], fill.text


def test_morph_units_and_normals_defaults_are_the_pipelines() -> None:
    from typing import get_args

    from conformorph.pipelines.face_morph import DEFAULT_NORMALS, DEFAULT_UNITS, UNIT_CHOICES
    from conformorph.service.schemas import NORMALS_DEFAULT, UNITS_DEFAULT, MorphCreate, Units

    assert (UNITS_DEFAULT, NORMALS_DEFAULT) == (DEFAULT_UNITS, DEFAULT_NORMALS)
    assert get_args(Units) == UNIT_CHOICES
    fields = MorphCreate.model_fields
    assert (fields["units"].default, fields["normals"].default) == (DEFAULT_UNITS, DEFAULT_NORMALS)


def test_face_morph_job_returns_key_0_at_its_input_resolution(api: Api, tmp_path: Path) -> None:
    """Decimated for the numerics (vertex_budget), written back at the uploaded resolution."""
    _needs_face_pipeline()
    import pygltflib

    V, F = small_face(30)  # 2,791 vertices
    W = V.copy()
    W[:, 2] += 3.0 * np.sin(V[:, 0] / 30.0)
    a, b = tmp_path / "a.obj", tmp_path / "b.obj"
    write_obj(a, V, F)
    write_obj(b, W, F)
    r = np.linalg.norm(V[:, :2] / np.array([80.0, 100.0]), axis=1)
    ring = np.flatnonzero(np.abs(r - 0.5) < 0.02)
    lm = [0, *[int(i) for i in ring[:: max(1, ring.size // 8)][:8]]]
    ids = [_upload(api, a), _upload(api, b)]
    body = {"meshes": ids, "landmarks": [lm, lm], "frames": 3, "prepare": "auto"}
    counts = {}
    for res in ("input", "working"):
        r2 = api.client.post(
            "/v1/morphs", json={**body, "vertex_budget": 1000, "output_resolution": res}
        )
        assert r2.status_code == 202, r2.text
        jid = r2.json()["id"]
        outs = api.run_job(jid)
        assert [o.status for o in outs] == ["ran"] * 5, outs[-1].job
        glb = api.client.get(f"/v1/jobs/{jid}/artifacts/animation.glb").content
        gl = pygltflib.GLTF2.load_from_bytes(glb)
        counts[res] = gl.accessors[gl.meshes[0].primitives[0].attributes.POSITION].count
    assert counts["input"] == V.shape[0] and counts["working"] < 1200
