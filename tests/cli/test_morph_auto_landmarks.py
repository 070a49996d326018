"""``conformorph morph … --landmarks auto`` (issue 16): detection on every key mesh, the file
beside the outputs, the report in metrics.json, and the named failures (exit 2, one line).

Detection needs mediapipe==0.10.14 and embreex (skipped otherwise); the committed face
(tests/fixtures/faces) runs without ../shared/data."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from conformorph.cli.main import main
from conformorph.pipelines.landmark_detection.mediapipe_detector import mediapipe_available
from conformorph.pipelines.landmarks_io import read_landmark_file
from conformorph.pipelines.mesh_io import read_mesh, write_obj
from tests.fixtures.fixture_faces import GPP_FACE, gpp_pair
from tests.meshes import spherical_cap

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "faces"


def _has_embree() -> bool:
    import trimesh

    return bool(trimesh.ray.has_embree)


needs_mediapipe = pytest.mark.skipif(
    not (mediapipe_available() and _has_embree()),
    reason="mediapipe==0.10.14 or embreex not installed (scripts/install_landmarks.sh)",
)


def _check_landmark_file(path: Path, meshes: list[Path]) -> dict:
    doc = json.loads(path.read_text())
    assert doc["layout"] == "multipie68_0based" and doc["meshes"] == [str(m) for m in meshes]
    entries = read_landmark_file(path, len(meshes))  # the file --landmarks reads
    assert [len(e) for e in entries] == [68] * len(meshes)
    for k, m in enumerate(meshes):
        V, F = read_mesh(m)
        conf = np.asarray(doc["confidence"][k])
        assert conf.shape == (68,) and np.all((conf >= 0) & (conf <= 1))
        pts = np.asarray(doc["landmarks"][k])
        tri, bary = np.asarray(doc["triangles"][k]), np.asarray(doc["barycentric"][k])
        # the ids index the mesh as read: the points lie in those triangles, the vertex ids
        # are corners of them
        assert np.allclose(np.einsum("mj,mjk->mk", bary, V[F[tri]]), pts, atol=1e-6)
        assert all(v in F[t] for v, t in zip(doc["vertex_ids"][k], tri, strict=True))
    return doc


@needs_mediapipe
def test_auto_landmarks_on_the_committed_face(tmp_path, capsys):
    keys = gpp_pair(tmp_path)
    out = tmp_path / "out"
    argv = [
        "morph",
        *map(str, keys),
        "--landmarks",
        "auto",
        "--remove-ears",
        "--frames",
        "4",
        "-o",
        str(out),
        "--json",
        "-q",
    ]
    assert main(argv) == 0
    captured = capsys.readouterr()
    metrics = json.loads(captured.out)
    doc = _check_landmark_file(out / "landmarks.json", keys)
    report = metrics["landmarks"]
    assert report["source"] == "auto" and report["file"] == "landmarks.json"
    assert json.loads((out / "metrics.json").read_text())["landmarks"] == report
    for k, m in enumerate(report["meshes"]):
        assert m["min_confidence"] == pytest.approx(min(doc["confidence"][k]), abs=1e-4)
        assert m["warnings"] == doc["warnings"][k]
    # every warning of the file is in metrics.json and on stderr
    flat = [w for ws in doc["warnings"] for w in ws]
    assert len(report["warnings"]) == len(flat)
    assert captured.err.count("warning: landmarks:") == len(flat)
    # the file goes back in as it is (a person edits it and passes it back)
    again = tmp_path / "again"
    argv = [
        "morph",
        *map(str, keys),
        "--landmarks",
        str(out / "landmarks.json"),
        "--remove-ears",
        "--frames",
        "4",
        "-o",
        str(again),
        "-q",
    ]
    assert main(argv) == 0
    assert "landmarks" not in json.loads((again / "metrics.json").read_text())


@needs_mediapipe
def test_auto_landmarks_name_the_failing_mesh_in_one_line(tmp_path, capsys):
    cap = tmp_path / "cap.obj"
    write_obj(cap, *spherical_cap(k=20))
    out = tmp_path / "out"
    assert main(["morph", str(GPP_FACE), str(cap), "--landmarks", "auto", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no face found" in err[0] and "cap.obj" in err[0]
    assert not (out / "landmarks.json").exists()


@needs_mediapipe
def test_a_face_seen_only_from_behind_is_named(tmp_path, capsys):
    # a plate in front of the face hides it: only the views from behind (the hollow face,
    # nose farther than the eyes) show a face
    V, F = read_mesh(GPP_FACE)
    lo, hi = V.min(axis=0), V.max(axis=0)
    z = lo[2] - 10.0  # the face looks towards -z
    plate = np.array(
        [
            [lo[0] - 5, lo[1] - 5, z],
            [hi[0] + 5, lo[1] - 5, z],
            [hi[0] + 5, hi[1] + 5, z],
            [lo[0] - 5, hi[1] + 5, z],
        ]
    )
    n = V.shape[0]
    hidden = tmp_path / "hidden.obj"
    write_obj(hidden, np.vstack([V, plate]), np.vstack([F, [[n, n + 1, n + 2], [n, n + 2, n + 3]]]))
    argv = ["morph", str(hidden), str(GPP_FACE), "--landmarks", "auto", "-o", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "from behind" in err[0] and "hidden.obj" in err[0]


def test_auto_landmarks_without_mediapipe_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    from conformorph.pipelines.landmark_detection import detect

    monkeypatch.setitem(sys.modules, "mediapipe", None)  # import mediapipe now fails
    monkeypatch.setattr(detect, "_MODELS", [])
    out = tmp_path / "out"
    assert main(["morph", str(GPP_FACE), str(GPP_FACE), "--landmarks", "auto", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "mediapipe==0.10.14" in err[0]
    assert not (out / "metrics.json").exists()


@needs_mediapipe
@pytest.mark.shared_data
@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data absent")
def test_auto_landmarks_on_shared_ict_faces_are_near_the_annotation(tmp_path):
    keys = [SHARED / "ict_generic_neutral.obj", SHARED / "ict_generic_smile.obj"]
    out = tmp_path / "out"
    argv = [
        "morph",
        *map(str, keys),
        "--landmarks",
        "auto",
        "--frames",
        "3",
        "--no-metrics",
        "-o",
        str(out),
        "-q",
    ]
    assert main(argv) == 0
    doc = _check_landmark_file(out / "landmarks.json", keys)
    truth = json.loads((SHARED / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    for k, m in enumerate(keys):
        V, _ = read_mesh(m)
        err = np.linalg.norm(np.asarray(doc["landmarks"][k]) - V[truth], axis=1)
        assert err[17:].mean() < 0.35  # cm: inner points within a few mm of the annotation
    assert (out / "animation.glb").exists()


@needs_mediapipe
def test_a_subset_named_by_ibug_index_is_filled_by_detection(tmp_path):
    """Issue 27: 5 given points ("indices", "fill": "auto") and the other 63 detected;
    the given ones keep full confidence and their vertices, the file reads as 68."""
    from conformorph.geometry.boundary_loop import boundary_loop
    from conformorph.geometry.static_correspondences import farthest_point_samples

    keys = gpp_pair(tmp_path)
    V, F = read_mesh(keys[0])
    rim = V[boundary_loop(F)]
    inner = np.linalg.norm(V[:, None, :] - rim[None], axis=2).min(axis=1)
    central = np.flatnonzero(inner > 0.5 * inner.max())  # well inside the face
    ids = [int(v) for v in farthest_point_samples(V, 5, candidates=central)]
    given = [ids, ids]  # the pair shares connectivity
    lm = tmp_path / "five.json"
    lm.write_text(json.dumps({"landmarks": given, "indices": [39, 42, 30, 48, 54], "fill": "auto"}))
    out = tmp_path / "out"
    argv = ["morph", *map(str, keys), "--landmarks", str(lm), "--remove-ears", "--frames", "4"]
    assert main([*argv, "-o", str(out), "-q"]) == 0
    doc = _check_landmark_file(out / "landmarks.json", keys)
    for k in range(2):
        assert [doc["vertex_ids"][k][i] for i in (39, 42, 30, 48, 54)] == given[k]
        assert [doc["confidence"][k][i] for i in (39, 42, 30, 48, 54)] == [1.0] * 5
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["landmarks"]["given_indices"] == [39, 42, 30, 48, 54]
    assert metrics["registration"]["landmark_fit"] == "tolerant"
