"""Landmark detection over HTTP with a real worker process (issue 16): the detection job, a
morph with ``"landmarks": "auto"``, its named failures, and a worker without mediapipe.

Detection needs mediapipe==0.10.14 and embreex in the worker's environment (skipped
otherwise); the meshes are the committed face (tests/fixtures/faces) and a sphere cap.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from conformorph.pipelines.landmark_detection.mediapipe_detector import mediapipe_available
from conformorph.pipelines.mesh_io import write_obj
from tests.fixtures.fixture_faces import gpp_pair
from tests.meshes import spherical_cap
from tests.worker.test_integration import Service, _env

pytestmark = pytest.mark.timeout(400)


def _has_embree() -> bool:
    import trimesh

    return bool(trimesh.ray.has_embree)


needs_mediapipe = pytest.mark.skipif(
    not (mediapipe_available() and _has_embree()),
    reason="mediapipe==0.10.14 or embreex not installed (scripts/install_landmarks.sh)",
)


def _service(tmp_path: Path, start_worker: Any, **extra: str) -> Service:
    env = _env(tmp_path, **extra)
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    svc.ready()
    return svc


@needs_mediapipe
def test_detection_job_then_morph_by_id_and_morph_auto(tmp_path: Path, start_worker: Any) -> None:
    svc = _service(tmp_path, start_worker)
    ids = [svc.upload(p) for p in gpp_pair(tmp_path)]
    det = svc.submit("/v1/landmark-detections", {"meshes": ids})
    auto = svc.submit(
        "/v1/morphs",
        {"meshes": ids, "landmarks": "auto", "remove_ears": True, "frames": 4},
    )
    job = svc.finished(det, timeout=180)
    assert job["state"] == "succeeded", job
    assert job["kind"] == "landmark_detection"
    assert [s["name"] for s in job["stages"]] == ["detect_landmarks"]
    assert [a["name"] for a in job["artifacts"]] == ["landmarks.json"]
    doc = svc.client.get(f"/v1/jobs/{det}/artifacts/landmarks.json").json()
    assert doc["meshes"] == ids and [len(x) for x in doc["landmarks"]] == [68, 68]
    assert [len(c) for c in doc["confidence"]] == [68, 68]
    set_id = doc.pop("landmarks_id")
    # the stored set: its summary, the document itself, and the id an upload of it gets
    summary = svc.client.get(f"/v1/landmarks/{set_id}").json()
    assert summary["meshes"] == 2 and summary["landmarks_per_mesh"] == 68
    stored = svc.client.get(f"/v1/landmarks/{set_id}/document").json()
    assert stored == doc
    again = svc.client.post("/v1/landmarks", json=doc)
    assert again.status_code == 200 and again.json()["id"] == set_id
    # edited (one point moved to a vertex) and uploaded, it morphs by id
    doc["landmarks"][1][30] = doc["vertex_ids"][1][30]
    edited = svc.client.post("/v1/landmarks", json=doc)
    assert edited.status_code == 201, edited.text
    by_id = svc.submit(
        "/v1/morphs",
        {"meshes": ids, "landmarks_id": edited.json()["id"], "remove_ears": True, "frames": 4},
    )
    job = svc.finished(auto, timeout=240)
    assert job["state"] == "succeeded", job
    assert [s["name"] for s in job["stages"]][:2] == ["detect_landmarks", "prepare"]
    assert {"landmarks.json", "animation.glb", "metrics.json"} <= {
        a["name"] for a in job["artifacts"]
    }
    metrics = svc.client.get(f"/v1/jobs/{auto}/artifacts/metrics.json").json()
    lm = svc.client.get(f"/v1/jobs/{auto}/artifacts/landmarks.json").json()
    assert metrics["landmarks"]["source"] == "auto"
    # detected landmarks get the tolerant fit by default (landmark_fit "auto")
    assert metrics["registration"]["landmark_fit"] == "tolerant"
    assert [m["warnings"] for m in metrics["landmarks"]["meshes"]] == lm["warnings"]
    # the same meshes, the same points (the timings in "detector" differ, so does the id)
    assert lm["landmarks"] == stored["landmarks"] and lm["landmarks_id"] != set_id
    job = svc.finished(by_id, timeout=240)
    assert job["state"] == "succeeded", job


def _five_given(path: Path) -> dict[str, Any]:
    """A landmark set of 5 central vertices of the committed face (shared by the pair), named
    by ibug index and asking for the other 63 to be detected (issue 27)."""
    import numpy as np

    from conformorph.geometry.boundary_loop import boundary_loop
    from conformorph.geometry.static_correspondences import farthest_point_samples
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(path)
    rim = V[boundary_loop(F)]
    inner = np.linalg.norm(V[:, None, :] - rim[None], axis=2).min(axis=1)
    central = np.flatnonzero(inner > 0.5 * inner.max())
    ids = [int(v) for v in farthest_point_samples(V, 5, candidates=central)]
    return {"landmarks": [ids, ids], "indices": [39, 42, 30, 48, 54], "fill": "auto"}


@needs_mediapipe
def test_a_landmark_set_asking_for_fill_is_filled_by_detection(
    tmp_path: Path, start_worker: Any
) -> None:
    """A stored subset with "fill": "auto" morphs as ``conformorph morph`` does with that
    file: the other 63 detected, the given ones kept, metrics saying which were which."""
    svc = _service(tmp_path, start_worker)
    keys = gpp_pair(tmp_path)
    ids = [svc.upload(p) for p in keys]
    five = _five_given(keys[0])
    r = svc.client.post("/v1/landmarks", json=five)
    assert r.status_code == 201, r.text
    job_id = svc.submit(
        "/v1/morphs",
        {"meshes": ids, "landmarks_id": r.json()["id"], "remove_ears": True, "frames": 4},
    )
    job = svc.finished(job_id, timeout=240)
    assert job["state"] == "succeeded", job
    assert [s["name"] for s in job["stages"]][:2] == ["detect_landmarks", "prepare"]
    doc = svc.client.get(f"/v1/jobs/{job_id}/artifacts/landmarks.json").json()
    assert [len(x) for x in doc["landmarks"]] == [68, 68]
    for k in range(2):
        assert [doc["vertex_ids"][k][i] for i in five["indices"]] == five["landmarks"][k]
        assert [doc["confidence"][k][i] for i in five["indices"]] == [1.0] * 5
    metrics = svc.client.get(f"/v1/jobs/{job_id}/artifacts/metrics.json").json()
    lm = metrics["landmarks"]
    assert lm["source"] == "auto" and lm["given_indices"] == five["indices"]
    assert lm["detected_indices"] == sorted(set(range(68)) - set(five["indices"]))
    assert metrics["registration"]["landmark_fit"] == "tolerant"  # as the CLI's default


@needs_mediapipe
def test_detection_failures_are_named(tmp_path: Path, start_worker: Any) -> None:
    svc = _service(tmp_path, start_worker)
    write_obj(tmp_path / "cap.obj", *spherical_cap(k=20))
    face = svc.upload(gpp_pair(tmp_path)[0])
    cap = svc.upload(tmp_path / "cap.obj")
    det = svc.submit("/v1/landmark-detections", {"meshes": [face, cap]})
    auto = svc.submit("/v1/morphs", {"meshes": [cap, face], "landmarks": "auto",
                                     "remove_ears": True})
    job = svc.finished(det, timeout=180)
    assert job["state"] == "failed"
    err = job["error"]
    assert err["type"] == "landmarks_not_detected" and err["field"] == "meshes[1]"
    assert err["message"].startswith("no_face_found:") and cap in err["message"]
    assert err["stage"] == "detect_landmarks"
    job = svc.finished(auto, timeout=180)
    assert job["state"] == "failed" and job["error"]["field"] == "meshes[0]"
    assert [s["state"] for s in job["stages"]][:2] == ["failed", "pending"]
    # requests the API itself turns down
    r = svc.client.post("/v1/landmark-detections", json={"meshes": []})
    assert r.status_code == 422
    r = svc.client.post("/v1/landmark-detections", json={"meshes": ["0" * 32]})
    assert r.status_code == 404 and r.json()["error"]["field"] == "meshes[0]"
    r = svc.client.post("/v1/morphs", json={"meshes": [face, face], "landmarks": "manual"})
    assert r.status_code == 422


def test_a_worker_without_mediapipe_fails_the_job_clearly(
    tmp_path: Path, start_worker: Any
) -> None:
    # a package named mediapipe that cannot be imported, first on the worker's path: the
    # worker sees what an install without it sees
    blocked = tmp_path / "blocked" / "mediapipe"
    blocked.mkdir(parents=True)
    (blocked / "__init__.py").write_text("raise ImportError(\"No module named 'mediapipe'\")\n")
    env = _env(tmp_path)
    env["PYTHONPATH"] = f"{blocked.parent}:{env['PYTHONPATH']}"
    start_worker(env, log=tmp_path / "worker.log")
    svc = Service(tmp_path, env)
    svc.ready()
    face = svc.upload(gpp_pair(tmp_path)[0])
    det = svc.submit("/v1/landmark-detections", {"meshes": [face]})
    job = svc.finished(det, timeout=120)
    assert job["state"] == "failed"
    assert job["error"]["type"] == "landmark_detection_unavailable"
    assert "mediapipe==0.10.14" in job["error"]["message"]
    # a landmark set asking for the missing points to be detected: the same named error
    r = svc.client.post("/v1/landmarks", json=_five_given(gpp_pair(tmp_path)[0]))
    assert r.status_code == 201, r.text
    fill = svc.submit(
        "/v1/morphs",
        {"meshes": [face, face], "landmarks_id": r.json()["id"], "remove_ears": True},
    )
    job = svc.finished(fill, timeout=120)
    assert job["state"] == "failed", job
    assert job["error"]["type"] == "landmark_detection_unavailable"
    assert job["error"]["stage"] == "detect_landmarks"
