"""Issue 30, item 11: a huge parameter (a 100k-entry anchor ``paths`` list) does not make
every GET of its job huge: values over 4 KB are shown by reference, and
``GET /v1/jobs/{id}/params`` returns them whole."""

from __future__ import annotations

import json
from pathlib import Path

from conformorph.worker.job_record import PARAM_INLINE_BYTES, params_by_reference
from tests.service.conftest import Api

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"


def _shape(api: Api, name: str) -> str:
    r = api.client.post("/v1/shapes", files={"file": (name, (SHAPES / name).read_bytes())})
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def test_a_huge_paths_list_is_returned_by_reference(api: Api) -> None:
    src, dst = _shape(api, "annulus_round.json"), _shape(api, "annulus_square.json")
    anchors = json.loads((SHAPES / "anchors_annulus_round__annulus_square.json").read_text())
    path = [0, 1] * 50_000  # 100k entries
    body = {"source": src, "target": dst, "anchors": anchors["anchors"], "paths": [path]}
    r = api.client.post("/v1/morphs2d", json=body)
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    for got in (r, api.client.get(f"/v1/jobs/{jid}"), api.client.get("/v1/jobs")):
        assert len(got.content) < 20_000, len(got.content)
    params = api.client.get(f"/v1/jobs/{jid}").json()["params"]
    assert params["paths"] == {"ref": f"/v1/jobs/{jid}/params#/paths", "entries": 1}
    assert params["anchors"] == anchors["anchors"]  # small values stay inline
    whole = api.client.get(f"/v1/jobs/{jid}/params")
    assert whole.status_code == 200 and whole.json()["paths"] == [path]
    assert whole.json()["source"] == src  # uploads by id, as in the record
    assert api.client.get(f"/v1/jobs/{'0' * 32}/params").status_code == 404


def test_params_by_reference_hand_worked() -> None:
    big = list(range(2000))  # about 8.9 KB of JSON
    small = [[0.5, 1.5]] * 10
    out = params_by_reference({"a": big, "b": small, "c": "x" * 10_000, "d": 3}, "/v1/jobs/j")
    assert out["a"] == {"ref": "/v1/jobs/j/params#/a", "entries": 2000}
    assert out["b"] == small and out["d"] == 3
    assert out["c"] == "x" * 10_000  # only lists and objects are referenced
    assert len(json.dumps(list(range(900)), separators=(",", ":"))) < PARAM_INLINE_BYTES
    assert params_by_reference({"a": list(range(900))}, "/j")["a"] == list(range(900))
