"""Automatic landmarks (conformorph.pipelines.landmark_detection): the table fit and its numerics run
everywhere; rendering needs embreex, detection needs mediapipe==0.10.14 (skipped otherwise)."""

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.landmark_detection import detection_errors as errs
from conformorph.pipelines.landmark_detection.detect import (
    DetectedLandmarks,
    DetectionOptions,
    FaceMeshView,
    choose_view,
    open_mouth_warning,
    surface_landmarks_from_pixels,
)
from conformorph.pipelines.landmark_detection.frontal_view import (
    candidate_cameras,
    principal_axes,
    roll_to_eyes,
    unrotate_pixels,
)
from conformorph.pipelines.landmark_detection.landmark_file import landmark_file_document
from conformorph.pipelines.landmark_detection.mediapipe_detector import (
    FaceDetection,
    mediapipe_available,
)
from conformorph.pipelines.landmark_detection.multipie68 import (
    load_multipie68_table,
    multipie68_from_facemesh,
    table_from_json,
)
from conformorph.pipelines.landmark_detection.multipie68_fit import (
    TableFitOptions,
    affine_weights,
    fit_multipie68_table,
)
from conformorph.pipelines.landmark_detection.render import OrthographicCamera
from conformorph.pipelines.landmark_document import parse_landmark_json
from tests.meshes import disk_grid, random_rotation, spherical_cap

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "faces"


def _has_embree() -> bool:
    import trimesh

    return bool(trimesh.ray.has_embree)


needs_embree = pytest.mark.skipif(
    not _has_embree(), reason="embreex not installed (ray casting; scripts/install_landmarks.sh)"
)
needs_mediapipe = pytest.mark.skipif(
    not (mediapipe_available() and _has_embree()),
    reason="mediapipe==0.10.14 or embreex not installed (scripts/install_landmarks.sh)",
)


def _camera(size: int = 64) -> OrthographicCamera:
    return OrthographicCamera(np.eye(3), np.zeros(3), 2.5 / size, size)


# --- the 478 -> 68 table ---------------------------------------------------------------------


def test_affine_weights_recover_an_exact_combination_and_sum_to_one():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(40, 4))
    w_true = np.array([0.5, 0.3, -0.1, 0.3])
    w = affine_weights(P, P @ w_true, np.array([1.0, 0, 0, 0]), ridge=0.0)
    np.testing.assert_allclose(w, w_true, atol=1e-10)
    # a huge ridge returns the prior, still summing to one
    w = affine_weights(P, rng.normal(size=40), np.array([1.0, 0, 0, 0]), ridge=1e9)
    np.testing.assert_allclose(w, [1, 0, 0, 0], atol=1e-6)
    assert abs(w.sum() - 1) < 1e-12


def test_table_fit_finds_the_facemesh_point_a_landmark_is():
    rng = np.random.default_rng(1)
    faces = [rng.uniform(0, 500, size=(478, 2)) for _ in range(3)]
    pick = rng.choice(478, size=68, replace=False)
    # the eye corners (33, 263) set the scale: the fit must not care about it
    targets = [f[pick] for f in faces]
    table = fit_multipie68_table(faces, targets, TableFitOptions(points_per_landmark=1, ridge=0.0))
    np.testing.assert_array_equal(table.index[:, 0], pick)
    for f, t in zip(faces, targets, strict=True):
        np.testing.assert_allclose(multipie68_from_facemesh(f, table), t, atol=1e-9)


def test_table_fit_with_several_points_is_translation_invariant():
    rng = np.random.default_rng(2)
    faces = [rng.uniform(0, 500, size=(478, 2)) for _ in range(4)]
    targets = [f[:68] * 0.5 + f[68:136] * 0.5 for f in faces]
    table = fit_multipie68_table(faces, targets, TableFitOptions(points_per_landmark=6, ridge=1e-3))
    shift = np.array([30.0, -12.0])
    a = multipie68_from_facemesh(faces[0], table)
    b = multipie68_from_facemesh(faces[0] + shift, table)
    np.testing.assert_allclose(b - a, np.tile(shift, (68, 1)), atol=1e-9)


def test_committed_table_loads_and_is_checked():
    table = load_multipie68_table()
    assert table.index.shape[0] == 68 and table.index.shape == table.weight.shape
    np.testing.assert_allclose(table.weight.sum(axis=1), 1.0, atol=1e-9)
    assert table.meta["held_out_error"]["mean_mm_68"] <= 3.0
    doc = table.to_json()
    with pytest.raises(ValueError, match="sum to 1"):
        table_from_json({**doc, "weight": [[2.0] + row[1:] for row in doc["weight"]]})
    with pytest.raises(ValueError, match="0..477"):
        table_from_json({**doc, "index": [[478] + row[1:] for row in doc["index"]]})
    with pytest.raises(ValueError, match="68"):
        table_from_json({**doc, "index": doc["index"][:5], "weight": doc["weight"][:5]})


# --- cameras and views (no rendering) ---------------------------------------------------------


def test_principal_axes_are_right_handed_and_sorted():
    rng = np.random.default_rng(3)
    V = rng.normal(size=(500, 3)) * [5.0, 3.0, 1.0]
    _, axes = principal_axes(V @ random_rotation(4).T)
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(axes) > 0
    var = ((V @ random_rotation(4).T) @ axes.T).var(axis=0)
    assert var[0] > var[1] > var[2]


def test_candidate_cameras_look_both_ways_with_right_handed_frames():
    V, _ = spherical_cap()
    cams = candidate_cameras(V, 128)
    assert len(cams) == 2
    for c in cams:
        np.testing.assert_allclose(np.cross(c.rotation[0], c.rotation[1]), c.rotation[2], atol=1e-12)
        px = c.project(V)
        assert px.min() >= 0 and px.max() <= 128
    assert cams[0].rotation[2] @ cams[1].rotation[2] < -0.999


def test_camera_rays_start_at_the_projected_pixel():
    cam = OrthographicCamera(random_rotation(5), np.array([1.0, 2, 3]), 0.01, 100)
    P = np.array([[1.1, 2.2, 2.9], [0.8, 2.0, 3.3]])
    o, d = cam.rays(cam.project(P), start=0.0)
    # the ray through a point's pixel passes through the point
    along = np.einsum("kd,kd->k", P - o, d)
    np.testing.assert_allclose(o + along[:, None] * d, P, atol=1e-12)


def test_unrotate_pixels_inverts_numpy_rot90():
    img = np.arange(36).reshape(6, 6)
    p = np.array([[1.5, 4.5], [0.5, 0.5]])
    for k in range(4):
        rot = np.rot90(img, k)
        q = unrotate_pixels(p, k, 6)
        for (x, y), (qx, qy) in zip(p, q, strict=True):
            assert rot[int(y), int(x)] == img[int(qy), int(qx)]


def test_roll_to_eyes_levels_the_eye_line():
    cam = _camera(100)
    right_px, left_px = np.array([30.0, 60.0]), np.array([70.0, 40.0])
    # the world points seen at those pixels
    o, _ = cam.rays(np.vstack([right_px, left_px]), start=0.0)
    rolled = roll_to_eyes(cam, right_px, left_px)
    px = rolled.project(o)
    assert abs(px[0, 1] - px[1, 1]) < 1e-9 and px[0, 0] < px[1, 0]


def test_open_mouth_lowers_inner_lip_confidence():
    pts = np.zeros((478, 2))
    pts[33], pts[263] = [100, 100], [200, 100]  # eye distance 100
    pts[13], pts[14] = [150, 200], [150, 202]
    conf = np.ones(68)
    assert open_mouth_warning(pts, conf, DetectionOptions()) is None and conf.min() == 1
    pts[14] = [150, 230]
    msg = open_mouth_warning(pts, conf, DetectionOptions())
    assert msg and "open mouth" in msg and "landmarks 61-68 have" in msg  # 1-based
    assert np.all(conf[60:68] < 0.5) and np.all(conf[:60] == 1)


def test_landmark_file_is_read_by_morph_landmarks():
    rng = np.random.default_rng(6)
    results = []
    for _ in range(2):
        results.append(DetectedLandmarks(
            points=rng.normal(size=(68, 3)), triangle=np.arange(68), barycentric=np.full((68, 3), 1 / 3),
            vertex=np.arange(68) * 2, confidence=np.full(68, 0.9), warnings=("w",), score=0.9,
            pixels=np.zeros((68, 2)), view=None,  # type: ignore[arg-type]
        ))
    doc = json.loads(json.dumps(landmark_file_document(results, ["a.obj", "b.obj"], {"name": "x"})))
    lists = parse_landmark_json(doc, 2)
    assert len(lists) == 2 and len(lists[0]) == 68
    np.testing.assert_allclose(lists[1], results[1].points, atol=1e-11)
    assert doc["vertex_ids"][1][3] == 6 and doc["confidence"][0][0] == 0.9
    assert doc["warnings"] == [["w"], ["w"]] and doc["layout"] == "multipie68_0based"


# --- rendering (embreex) ----------------------------------------------------------------------


@needs_embree
def test_cast_returns_the_exact_surface_point_of_a_pixel():
    from conformorph.pipelines.landmark_detection.render import MeshRayCaster

    V, F = spherical_cap(k=12)
    caster = MeshRayCaster(V, F)
    cam = OrthographicCamera(np.eye(3), np.array([0.0, 0, 0.5]), 2.4 / 64, 64)
    pix = np.array([[32.0, 32.0], [20.3, 41.7], [0.2, 0.2]])
    hits = caster.cast(cam, pix)
    assert hits.hit.tolist() == [True, True, False]
    P = np.einsum("kj,kjd->kd", hits.barycentric[:2], V[F[hits.triangle[:2]]])
    np.testing.assert_allclose(cam.project(P), pix[:2], atol=1e-9)
    np.testing.assert_allclose(hits.barycentric[:2].sum(axis=1), 1.0)
    # the nearest hit: the cap's top (z near 1), not its far side
    assert np.all(P[:, 2] > 0.5)


@needs_embree
def test_render_shades_the_surface_and_leaves_the_background_black():
    from conformorph.pipelines.landmark_detection.render import MeshRayCaster

    V, F = disk_grid(10)
    caster = MeshRayCaster(V, F)
    r = caster.render(OrthographicCamera(np.eye(3), np.zeros(3), 2.4 / 48, 48))
    inside = r.triangle >= 0
    assert inside[24, 24] and not inside[0, 0]
    assert r.image[0, 0] == 0 and r.image[24, 24] == 240  # flat disk facing the light
    assert r.rgb().shape == (48, 48, 3)
    np.testing.assert_allclose(r.depth[inside], 0.0, atol=1e-9)


class FakeModels:
    """Stands in for MediaPipe: one detection at fixed pixels in the unrotated image (k = 0)."""

    def __init__(self, score, box_width, nose_depth_front=True):
        self.score, self.box_width, self.front = score, box_width, nose_depth_front

    def detect_face(self, rgb):
        if rgb.shape[0] != 256 or not self._k0(rgb):
            return None
        c, w = 128.0, self.box_width
        nose = [128.0, 128.0] if self.front else [250.0, 250.0]  # far corner: the background
        kp = np.array([[110.0, 115.0], [146.0, 115.0], nose, [128.0, 150.0], [90, 120], [166, 120]])
        return FaceDetection(self.score, np.array([c - w / 2, c - w / 2, c + w / 2, c + w / 2]), kp)

    def _k0(self, rgb):
        self.calls = getattr(self, "calls", 0) + 1
        return self.calls % 4 == 1  # the first of the four quarter turns of each candidate


@needs_embree
@pytest.mark.parametrize(
    ("models", "error"),
    [
        (FakeModels(0.3, 100), errs.LowDetectorScoreError),
        (FakeModels(0.9, 8), errs.MeshTooSmallError),
        (FakeModels(0.9, 100, nose_depth_front=False), errs.ViewFromBehindError),
    ],
)
def test_choose_view_names_its_failures(models, error):
    from conformorph.pipelines.landmark_detection.render import MeshRayCaster

    V, F = spherical_cap(k=12)
    with pytest.raises(error):
        choose_view(MeshRayCaster(V, F), models, DetectionOptions())


@needs_embree
def test_choose_view_frames_the_best_front_detection():
    from conformorph.pipelines.landmark_detection.render import MeshRayCaster

    V, F = spherical_cap(k=12)
    cam, score = choose_view(MeshRayCaster(V, F), FakeModels(0.9, 100), DetectionOptions())
    assert score == 0.9 and cam.size == 512
    # eyes 36 px apart in a 256 px render: in the final view 0.3 * 512 px for 1.3 x that
    assert cam.pixel_size > 0


@needs_embree
def test_lost_rays_take_the_nearest_surface_pixel_or_fail():
    from conformorph.pipelines.landmark_detection.render import MeshRayCaster

    V, F = disk_grid(10)
    caster = MeshRayCaster(V, F)
    render = caster.render(OrthographicCamera(np.eye(3), np.zeros(3), 2.4 / 48, 48))
    view = FaceMeshView(render, np.zeros((478, 2)), 0.8)
    pix = np.array([[24.0, 24.0], [24.0, 1.0], [30.0, 20.0]])  # the second is off the disk
    tri, bary, conf, warn = surface_landmarks_from_pixels(caster, view, pix, DetectionOptions())
    # numbered as people read them: the second landmark is landmark 2
    assert (tri >= 0).all() and warn and "landmarks 2 missed" in warn[0]
    assert conf[1] < conf[0] and abs(conf[0] - 0.8) < 1e-9
    with pytest.raises(errs.RaysLostError):
        surface_landmarks_from_pixels(caster, view, pix, DetectionOptions(max_lost_rays=0))


# --- detection with MediaPipe -----------------------------------------------------------------


def _ict(name):
    from conformorph.pipelines.mesh_io import read_mesh

    return read_mesh(SHARED / f"{name}.obj")


@needs_mediapipe
def test_no_face_on_a_sphere_cap():
    from conformorph.pipelines.landmark_detection.detect import detect_landmarks

    V, F = spherical_cap(k=20)
    with pytest.raises(errs.NoFaceFoundError):
        detect_landmarks(V, F)


@needs_mediapipe
@pytest.mark.shared_data
@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data absent")
def test_ict_landmarks_match_the_annotation_and_survive_rotation():
    from conformorph.pipelines.landmark_detection.detect import detect_landmarks

    V, F = _ict("ict_rand1_neutral")
    truth = V[json.loads((SHARED / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]]
    r = detect_landmarks(V, F)
    err = np.linalg.norm(r.points - truth, axis=1)
    assert err.mean() < 0.35 and err[17:].mean() < 0.3  # cm (calibration saw this face)
    assert r.confidence.shape == (68,) and 0 < r.confidence.min() <= r.confidence.max() <= 1
    Q = random_rotation(7)
    rr = detect_landmarks(V @ Q.T + [3.0, -1.0, 2.0], F)
    # the same surface points, by barycentrics on the unrotated mesh
    P = np.einsum("mj,mjk->mk", rr.barycentric, V[F[rr.triangle]])
    assert np.linalg.norm(P - r.points, axis=1).max() < 0.01  # 0.1 mm


@needs_mediapipe
@pytest.mark.shared_data
@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data absent")
def test_cli_writes_a_file_morph_reads_and_fails_in_one_line(tmp_path, capsys):
    from conformorph.cli.main import main
    from conformorph.pipelines.landmarks_io import read_landmark_file

    out = tmp_path / "L.json"
    mesh = str(SHARED / "ict_generic_jawOpen.obj")
    assert main(["landmarks", mesh, "-o", str(out), "--preview", str(tmp_path), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["meshes"][0]["warnings"] and "open mouth" in summary["meshes"][0]["warnings"][-1]
    assert len(read_landmark_file(out, 1)[0]) == 68
    assert (tmp_path / "ict_generic_jawOpen_landmarks.png").exists()
    from conformorph.pipelines.mesh_io import write_obj

    cap = tmp_path / "cap.obj"
    write_obj(cap, *spherical_cap(k=20))
    assert main(["landmarks", str(cap), "-o", str(tmp_path / "no.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no face found" in err[0] and "cap.obj" in err[0]


def test_cli_without_mediapipe_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    import sys

    from conformorph.cli.main import main
    from conformorph.pipelines.landmark_detection import detect
    from conformorph.pipelines.mesh_io import write_obj

    monkeypatch.setitem(sys.modules, "mediapipe", None)  # import mediapipe now fails
    monkeypatch.setattr(detect, "_MODELS", [])
    cap = tmp_path / "cap.obj"
    write_obj(cap, *spherical_cap(k=6))
    assert main(["landmarks", str(cap), "-o", str(tmp_path / "L.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "mediapipe==0.10.14" in err[0]
    assert not (tmp_path / "L.json").exists()
