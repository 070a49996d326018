"""Issue 30, item 8 at the API: what the upload report knows is checked at submission
(a texture on a mesh without texture coordinates: 422 naming textures[i], not a job that
fails later with a server path and a CLI flag)."""

from __future__ import annotations

import io
from pathlib import Path

from PIL import Image

from conformorph.pipelines.mesh_io import write_obj
from conformorph.pipelines.mesh_texture_coordinates import has_texture_coordinates
from tests.fixtures.make_service_small_face import small_face
from tests.service.conftest import Api


def _png() -> bytes:
    buf = io.BytesIO()
    Image.new("RGB", (8, 8), (200, 10, 10)).save(buf, "PNG")
    return buf.getvalue()


def test_texture_on_a_mesh_without_uvs_is_422_at_submission(api: Api, tmp_path: Path) -> None:
    V, F = small_face(6)
    plain = tmp_path / "plain.obj"
    write_obj(plain, V, F)
    text = plain.read_text()
    uv_lines = "".join(f"vt {x:.4f} {y:.4f}\n" for x, y in (V[:, :2] - V[:, :2].min(0)) / 200)
    faces = "".join(f"f {a}/{a} {b}/{b} {c}/{c}\n" for a, b, c in F + 1)
    uved = tmp_path / "uved.obj"
    uved.write_text(
        "".join(ln + "\n" for ln in text.splitlines() if ln.startswith("v ")) + uv_lines + faces
    )
    ids = {}
    for p in (plain, uved):
        r = api.upload(p)
        assert r.status_code == 201, r.text
        ids[p.stem] = r.json()["id"]
        assert r.json()["report"]["texture_coordinates"] is (p is uved)
    tex = api.client.post("/v1/textures", files={"file": ("t.png", _png())}).json()["id"]
    lm = [[0, 1, 2], [0, 1, 2]]
    body = {"meshes": [ids["uved"], ids["plain"]], "landmarks": lm, "textures": [tex, tex]}
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["type"] == "mesh_without_texture_coordinates" and err["field"] == "textures[1]"
    assert "/" not in err["message"] and "--" not in err["message"]
    assert api.tasks.submitted == []
    body["meshes"] = [ids["uved"], ids["uved"]]
    assert api.client.post("/v1/morphs", json=body).status_code == 202


def test_texture_coordinate_detection_by_format() -> None:
    assert has_texture_coordinates(b"v 0 0 0\n  vt 0 0\nf 1 1 1\n", "obj")
    assert not has_texture_coordinates(b"v 0 0 0\n# vt 0 0\nvn 0 0 1\n", "obj")
    ply = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float s\n"
    assert has_texture_coordinates(ply + b"end_header\n0 0\n", "ply")
    assert not has_texture_coordinates(ply.replace(b" s\n", b" y\n") + b"end_header\n", "ply")
    assert has_texture_coordinates(b'glTF....{"attributes":{"TEXCOORD_0":3}}', "glb")
    assert not has_texture_coordinates(b"solid x\nendsolid\n", "stl")
