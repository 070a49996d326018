"""``landmark_provenance`` (issue 31): where the viewer's landmarks came from reaches the
job's metrics, with the fit the registration used; a mismatched list is a 422 naming it."""

from __future__ import annotations

from pathlib import Path

import pytest

from conformorph.pipelines.landmark_document import landmark_provenance_report
from tests.service.conftest import Api
from tests.service.test_morphs import _upload, face_pair  # noqa: F401  (a fixture)


def test_provenance_report_counts_and_lists_what_a_person_placed() -> None:
    r = landmark_provenance_report(
        [["detected", "moved", "detected"], ["picked", "picked", "file"]], "tolerant"
    )
    assert r["source"] == "request" and r["fit"] == "tolerant"
    assert r["counts"] == {"detected": 2, "moved": 1, "picked": 2, "file": 1}
    assert r["meshes"][0] == {"counts": {"detected": 2, "moved": 1}, "moved": [1]}
    assert r["meshes"][1] == {"counts": {"picked": 2, "file": 1}, "picked": [0, 1]}


def test_morph_metrics_say_where_the_landmarks_came_from(
    api: Api, face_pair: tuple[Path, Path, list[int]]  # noqa: F811
) -> None:
    pytest.importorskip("conformorph.pipelines.face_morph")
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    prov = [["detected"] * len(lm), ["detected"] * len(lm)]
    prov[1][2] = "moved"
    body = {"meshes": ids, "landmarks": [lm, lm], "frames": 3}
    for bad, field in (
        ([["detected"] * len(lm)], "landmark_provenance"),
        ([prov[0], prov[1][:-1]], "landmark_provenance[1]"),
        ([prov[0], ["guessed"] * len(lm)], None),
    ):
        r = api.client.post("/v1/morphs", json={**body, "landmark_provenance": bad})
        assert r.status_code == 422, r.text
        if field is not None:
            assert r.json()["error"]["field"] == field, r.text
    r = api.client.post("/v1/morphs", json={**body, "landmark_provenance": prov})
    assert r.status_code == 202, r.text
    jid = r.json()["id"]
    api.run_job(jid)
    metrics = api.client.get(f"/v1/jobs/{jid}/artifacts/metrics.json").json()
    entry = metrics["landmarks"]
    assert entry["source"] == "request" and entry["fit"] == "exact"
    assert entry["counts"] == {"detected": 2 * len(lm) - 1, "moved": 1}
    assert entry["meshes"][1]["moved"] == [2]
    # without it, no landmarks entry (as before)
    r = api.client.post("/v1/morphs", json=body)
    api.run_job(r.json()["id"])
    plain = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/metrics.json").json()
    assert "landmarks" not in plain
