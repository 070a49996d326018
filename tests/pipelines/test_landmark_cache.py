"""Detected landmarks through the key cache: found again only for the same bytes and
detection options, equal to the detection itself, a damaged entry detected again."""

from __future__ import annotations

from pathlib import Path

import pytest

from conformorph.pipelines.face_morph.key_cache import DirectoryArtifactStore
from conformorph.pipelines.face_morph.landmark_cache import (
    PER_MESH,
    cached_detection_document,
    detection_key,
)
from conformorph.pipelines.landmark_detection.mediapipe_detector import mediapipe_available
from tests.fixtures.fixture_faces import gpp_pair


def _has_embree() -> bool:
    import trimesh

    return bool(trimesh.ray.has_embree)


needs_mediapipe = pytest.mark.skipif(
    not (mediapipe_available() and _has_embree()),
    reason="mediapipe==0.10.14 or embreex not installed (scripts/install_landmarks.sh)",
)


def test_key_follows_bytes_and_options() -> None:
    from conformorph.pipelines.landmark_detection.detect import DetectionOptions

    a = detection_key("a" * 64, None)
    assert a == detection_key("a" * 64, DetectionOptions())
    assert a != detection_key("b" * 64, None)
    assert a != detection_key("a" * 64, DetectionOptions(image_size=640))


@needs_mediapipe
def test_cached_detection_equals_the_detection(tmp_path: Path) -> None:
    from conformorph.pipelines.landmark_detection.key_landmarks import detect_key_landmarks
    from conformorph.pipelines.mesh_io import read_mesh

    keys = gpp_pair(tmp_path)
    store = DirectoryArtifactStore(tmp_path / "cache")
    first = cached_detection_document(keys, store)
    assert first["detector"]["cache"] == ["stored", "stored"]
    second = cached_detection_document(keys, store)
    assert second["detector"]["cache"] == ["hit", "hit"]
    assert second["detector"]["model_load_seconds"] == 0.0
    fresh = detect_key_landmarks([read_mesh(k) for k in keys], [str(k) for k in keys])
    for doc in (first, second):
        assert {k: doc[k] for k in PER_MESH} == {k: fresh[k] for k in PER_MESH}
        assert doc["detector"]["score"] == fresh["detector"]["score"]
        assert doc["meshes"] == fresh["meshes"] and doc["layout"] == fresh["layout"]
    # other bytes of mesh 1 (a comment line): detected again, mesh 0 still found
    keys[1].write_bytes(keys[1].read_bytes() + b"# edited\n")
    assert cached_detection_document(keys, store)["detector"]["cache"] == ["hit", "stored"]
    # a damaged entry is detected again
    (f,) = [
        p
        for p in store.root.iterdir()
        if p.stat().st_mtime == max(q.stat().st_mtime for q in store.root.iterdir())
    ]
    f.write_bytes(f.read_bytes()[:40])
    assert cached_detection_document(keys, store)["detector"]["cache"] == ["hit", "replaced"]
