"""The key-mesh wrapper of landmark detection (``--landmarks auto``, the detection stage):
its report, its checks, the stages of an auto morph and the stored set's id."""

from __future__ import annotations

import sys

import pytest

from conformorph.pipelines.landmark_detection.key_landmarks import (
    LandmarkDetectionUnavailableError,
    detect_key_landmarks,
    landmark_report,
)
from conformorph.pipelines.landmark_detection.mediapipe_detector import mediapipe_available
from conformorph.worker import names
from tests.meshes import spherical_cap


def _doc() -> dict:
    return {
        "landmarks": [[[0.0, 0.0, 0.0]] * 3, [[1.0, 0.0, 0.0]] * 3],
        "meshes": ["a.obj", "b.obj"],
        "confidence": [[0.9, 0.4, 0.7], [0.2, 0.8, 0.49]],
        "warnings": [[], ["open mouth", "rays lost"]],
        "detector": {"score": [0.93, 0.71]},
    }


def test_report_worked_by_hand():
    r = landmark_report(_doc(), "L.json")
    assert r["source"] == "auto" and r["file"] == "L.json"
    a, b = r["meshes"]
    assert (a["mesh"], a["score"], a["min_confidence"], a["low_confidence"]) == ("a.obj", 0.93, 0.4, [1])
    assert (b["min_confidence"], b["low_confidence"]) == (0.2, [0, 2])
    assert r["warnings"] == ["b.obj: open mouth", "b.obj: rays lost"]


def test_report_needs_one_entry_per_mesh():
    doc = _doc()
    doc["warnings"] = [[]]
    with pytest.raises(ValueError):
        landmark_report(doc)


def test_detect_checks_its_arguments():
    V, F = spherical_cap(k=4)
    with pytest.raises(ValueError, match="2 names"):
        detect_key_landmarks([(V, F)], ["a", "b"])
    with pytest.raises(ValueError, match="no mesh"):
        detect_key_landmarks([], [])


def test_without_mediapipe_the_error_is_named(monkeypatch):
    from conformorph.pipelines.landmark_detection import detect

    monkeypatch.setitem(sys.modules, "mediapipe", None)
    monkeypatch.setattr(detect, "_MODELS", [])
    V, F = spherical_cap(k=4)
    with pytest.raises(LandmarkDetectionUnavailableError) as info:
        detect_key_landmarks([(V, F)], ["cap"])
    assert info.value.code == "landmark_detection_unavailable"
    assert "mediapipe==0.10.14" in str(info.value)


@pytest.mark.skipif(not mediapipe_available(), reason="mediapipe==0.10.14 not installed")
def test_a_failure_names_the_mesh_and_its_index():
    from conformorph.pipelines.landmark_detection.detection_errors import NoFaceFoundError
    from conformorph.pipelines.mesh_io import read_mesh
    from tests.fixtures.fixture_faces import GPP_FACE

    face = read_mesh(GPP_FACE)
    cap = spherical_cap(k=20)
    with pytest.raises(NoFaceFoundError) as info:
        detect_key_landmarks([face, cap], ["face.obj", "cap.obj"])
    assert str(info.value).startswith("cap.obj: ") and info.value.mesh_index == 1


def test_an_auto_morph_detects_first_and_other_jobs_are_unchanged():
    morph = names.KIND_STAGES[names.KIND_MORPH]
    assert names.stages_for(names.KIND_MORPH, {"landmarks": "auto"}) == [
        names.STAGE_DETECT_LANDMARKS, *morph
    ]
    assert names.stages_for(names.KIND_MORPH, {"landmarks": [[0, 1, 2]] * 2}) == morph
    assert names.stages_for(names.KIND_LANDMARK_DETECTION, {}) == [names.STAGE_DETECT_LANDMARKS]
    assert names.stages_for(names.KIND_MORPH2D, {"landmarks": "auto"}) == [names.STAGE_MORPH2D]


def test_the_stored_set_gets_the_id_an_upload_gets():
    import json

    from conformorph.service.api.uploads import content_id
    from conformorph.worker.stages.landmark_detection import landmark_set_id

    doc = _doc()
    blob = json.dumps(doc, sort_keys=True, separators=(",", ":"))
    assert landmark_set_id("alice", doc) == content_id("alice", blob, "landmarks")
    assert landmark_set_id("bob", doc) != landmark_set_id("alice", doc)
    doc["confidence"][0][0] = 0.8
    assert landmark_set_id("alice", doc) != content_id("alice", blob, "landmarks")
