"""Issue 30, item 7: values that passed validation and crashed the job are refused at
submission or upload (422 ``out_of_range`` naming the entry), from the ranges the CLI,
the client and batch manifests share (``conformorph.pipelines.job_fields``); issue 27:
the API's morph defaults are the CLI's."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.mesh_io import write_obj
from tests.fixtures.make_service_small_face import small_face
from tests.service.conftest import Api


@pytest.fixture
def mesh_ids(api: Api, tmp_path: Path) -> list[str]:
    V, F = small_face(6)
    ids = []
    for k in range(2):
        p = tmp_path / f"f{k}.obj"
        write_obj(p, V * (1 + 0.01 * k), F)
        r = api.upload(p)
        assert r.status_code == 201, r.text
        ids.append(r.json()["id"])
    return ids


HOSTILE = [
    ({"times": [0, 1e308]}, "times[1]"),
    ({"times": [0, 1e-320]}, "times"),
    ({"frame_times": [-1e6, 1e6]}, "frame_times[0]"),
    ({"frame_times": [0, 1e308]}, "frame_times[1]"),
    ({"times": [0, 1], "frame_times": [0, 1, 5]}, "frame_times[2]"),
    ({"times": [0, 1], "frame_times": [0, 1e-9]}, "frame_times[1]"),
]


@pytest.mark.parametrize(("fields", "where"), HOSTILE)
def test_extreme_times_are_422_at_submission(
    api: Api, mesh_ids: list[str], fields: dict, where: str
) -> None:
    body = {"meshes": mesh_ids, "landmarks": [[0, 1, 2], [0, 1, 2]], **fields}
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 422, r.text
    err = r.json()["error"]
    assert err["type"] == "out_of_range" and err["field"] == where, err
    assert api.tasks.submitted == []


def test_well_posed_times_are_accepted_with_the_clis_defaults(
    api: Api, mesh_ids: list[str]
) -> None:
    body = {
        "meshes": mesh_ids,
        "landmarks": [[0, 1, 2], [0, 1, 2]],
        "times": [0, 2],
        "frame_times": [-2, 0, 1, 4],
    }
    r = api.client.post("/v1/morphs", json=body)
    assert r.status_code == 202, r.text
    params = r.json()["params"]
    # issue 27: one definition of the defaults (the CLI's: prepare auto, budget 50,000)
    assert params["prepare"] == "auto" and params["vertex_budget"] == 50_000
    assert params["landmark_fit"] == "auto"


def test_landmark_confidence_outside_0_1_or_misshapen_is_422(api: Api) -> None:
    lm = [[0, 1, 2], [0, 1, 2]]
    ok = api.client.post("/v1/landmarks", json={"landmarks": lm, "confidence": [[1, 0.5, 0]] * 2})
    assert ok.status_code == 201, ok.text
    for conf, where in (
        ([[1, 0.5, 1.5], [1, 1, 1]], "confidence[0][2]"),
        ([[1, 0.5, -1], [1, 1, 1]], "confidence[0][2]"),
        ([[1, 0.5], [1, 1, 1]], "confidence[0]"),
        ([[1, 1, 1]], "confidence"),
        ([[1, 1, 1], [1, "x", 1]], "confidence[1][1]"),
    ):
        r = api.client.post("/v1/landmarks", json={"landmarks": lm, "confidence": conf})
        assert r.status_code == 422, (conf, r.text)
        assert r.json()["error"]["type"] == "out_of_range"
        assert r.json()["error"]["field"] == where, r.json()
    r = api.client.post("/v1/landmarks", json={"landmarks": [[0, 1, [1e300, 0, 0]], [0, 1, 2]]})
    assert r.status_code == 422 and r.json()["error"]["field"] == "landmarks[0][2]", r.text


def test_shape_with_extreme_coordinates_is_422_at_upload(api: Api) -> None:
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    for pts in (square * 1e300, square + 1e11):
        doc = json.dumps({"rings": [pts.tolist()]}).encode()
        r = api.client.post("/v1/shapes", files={"file": ("s.json", doc)})
        assert r.status_code == 422, r.text
        assert r.json()["error"]["type"] == "out_of_range", r.json()
    doc = json.dumps({"rings": [(square * 1e6).tolist()]}).encode()
    assert api.client.post("/v1/shapes", files={"file": ("s.json", doc)}).status_code == 201


def test_mesh_with_extreme_coordinates_is_422_at_upload(api: Api, tmp_path: Path) -> None:
    V, F = small_face(5)
    for k, (scale, shift) in enumerate(((1e300, 0.0), (1e20, 0.0), (1.0, 1e12 - 1.0))):
        p = tmp_path / f"m{k}.obj"
        write_obj(p, V * scale + np.array([shift, 0.0, 0.0]), F)
        r = api.upload(p)
        assert r.status_code == 422, (scale, shift, r.text)
        assert r.json()["error"]["type"] == "out_of_range", r.json()
    p = tmp_path / "ok.obj"
    write_obj(p, V * 1e6, F)  # large, and honoured
    assert api.upload(p).status_code == 201
