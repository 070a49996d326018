"""Ids the service cannot have made never reach the job store, on SQLite and PostgreSQL.

PostgreSQL refuses NUL in text (psycopg raises DataError), so before these checks
``GET /v1/jobs/%00`` or ``{"mesh": "\\u0000"}`` answered 500 there.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from conformorph.service.schemas import ID_PATTERN, is_item_id
from tests.service.conftest import Api


@pytest.fixture(params=["sqlite", "postgresql"])
def any_api(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Api]:
    overrides = {}
    if request.param == "postgresql":
        overrides["database_url"] = request.getfixturevalue("pg_url")
    a = Api(tmp_path, **overrides)
    yield a
    a.client.close()
    a.store.dispose()


def test_the_id_pattern() -> None:
    assert is_item_id("0123456789abcdef" * 2)
    for bad in ("", "\x00", "A" * 32, "a" * 31, "a" * 33, "a" * 32 + "\n", "g" * 32, "é" * 32):
        assert not is_item_id(bad), bad
    assert re.fullmatch(ID_PATTERN, "f" * 32)


def test_ids_we_make_match_the_pattern(any_api: Api, small_face_path: Path) -> None:
    mesh = any_api.upload(small_face_path).json()["id"]
    doc = any_api.client.post("/v1/landmarks", json={"landmarks": [[0, 1, 2], [0, 1, 2]]})
    job = any_api.client.post("/v1/conformal-maps", json={"mesh": mesh})
    assert job.status_code == 202, job.text
    for made in (mesh, doc.json()["id"], job.json()["id"]):
        assert is_item_id(made), made


@pytest.mark.parametrize(
    "path",
    [
        "/v1/jobs/%00",
        "/v1/jobs/%00/events",
        "/v1/jobs/%00/artifacts/animation.glb",
        "/v1/meshes/%00",
        "/v1/meshes/a%00b",
        "/v1/textures/%00",
        "/v1/shapes/%00",
        "/v1/landmarks/%00",
        "/v1/jobs/" + "A" * 32,
        "/viewer/%00",
    ],
)
def test_odd_path_ids_are_404(any_api: Api, path: str) -> None:
    r = any_api.client.get(path)
    assert r.status_code == 404, r.text
    assert r.json()["error"]["type"] == "not_found"
    assert any_api.client.delete("/v1/jobs/%00").status_code == 404
    assert any_api.client.head("/v1/jobs/%00/artifacts/x").status_code == 404


@pytest.mark.parametrize(
    ("route", "body", "field"),
    [
        ("/v1/conformal-maps", {"mesh": "\u0000"}, "mesh"),
        ("/v1/reconstructions", {"mesh": "a\u0000" * 16}, "mesh"),
        ("/v1/morphs", {"meshes": ["\u0000", "0" * 32], "landmarks": [[0, 1, 2]] * 2}, "meshes[0]"),
        (
            "/v1/morphs",
            {"meshes": ["0" * 32, "1" * 32], "landmarks_id": "\u0000"},
            "landmarks_id",
        ),
        (
            "/v1/morphs",
            {"meshes": ["0" * 32] * 2, "landmarks": [[0, 1, 2]] * 2, "textures": ["\u0000"] * 2},
            "textures[0]",
        ),
        ("/v1/morphs2d", {"source": "\u0000", "target": "0" * 32, "anchors": []}, "source"),
        (
            "/v1/morphs2d",
            {
                "source": "0" * 32,
                "target": "0" * 32,
                "anchors": [[[0, 0], [0, 0]]] * 2,
                "texture": "\u0000",
            },
            "texture",
        ),
    ],
)
def test_odd_body_ids_are_422(
    any_api: Api, route: str, body: dict[str, object], field: str
) -> None:
    r = any_api.client.post(route, json=body)
    assert r.status_code == 422, r.text
    assert r.json()["error"]["field"] == field
    assert any_api.tasks.submitted == []


def test_nul_in_the_idempotency_key_and_the_file_name(any_api: Api, small_face_path: Path) -> None:
    # by hand: httpx would percent-encode the NUL in the file name
    body = (
        b'--XyZ\r\nContent-Disposition: form-data; name="file"; filename="fa\x00ce\x01.obj"\r\n'
        b"Content-Type: application/octet-stream\r\n\r\n"
        + small_face_path.read_bytes()
        + b"\r\n--XyZ--\r\n"
    )
    r = any_api.client.post(
        "/v1/meshes", content=body, headers={"content-type": "multipart/form-data; boundary=XyZ"}
    )
    assert r.status_code == 201, r.text
    assert r.json()["filename"] == "face.obj"
    r = any_api.client.post(
        "/v1/conformal-maps", json={"mesh": r.json()["id"]}, headers={"Idempotency-Key": "a\x00b"}
    )
    assert r.status_code == 422 and r.json()["error"]["field"] == "Idempotency-Key", r.text
    assert any_api.tasks.submitted == []
