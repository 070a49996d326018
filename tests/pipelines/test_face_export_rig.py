"""The face GLBs as an animator opens them (issue 29): metres, an identity rest transform,
rigid motion without scale, names, lighting at every frame, key frames matching the
per-frame files. Decoded in Python as three.js and Babylon play them (glb_playback)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pygltflib import GLTF2

from conformorph.geometry.vertex_normals import vertex_normals
from conformorph.pipelines.mesh_io import read_mesh

from .face_fixtures import write_obj
from .face_morph_inputs import SHARED, morph, validate_glb
from .glb_playback import MorphGlb, read_accessor, three_playback

pytestmark = [
    pytest.mark.shared_data,
    pytest.mark.skipif(not SHARED.exists(), reason="../shared/data absent"),
]


def _angles(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(np.sum(A * B, axis=1), -1.0, 1.0)))


def _true_normals(P: np.ndarray, F: np.ndarray) -> np.ndarray:
    N = vertex_normals(P, F)
    return N / np.linalg.norm(N, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def ict_morph(tmp_path_factory):
    """neutral (cm) → smile (written in mm) → jawOpen (cm), exact landmarks, 5 frames."""
    tmp = tmp_path_factory.mktemp("ict")
    lm = json.loads((SHARED / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    L = tmp / "l.json"
    L.write_text(json.dumps({"landmarks": [lm] * 3}))
    V, F = read_mesh(SHARED / "ict_generic_smile.obj")
    smile_mm = write_obj(tmp / "smile_mm.obj", V * 10.0, F)
    paths = [SHARED / "ict_generic_neutral.obj", smile_mm, SHARED / "ict_generic_jawOpen.obj"]
    out = tmp / "o"
    metrics = morph(paths, L, out, frames=5, per_frame=True, key_metrics=False)
    return out, metrics


def test_units_inferred_per_key_and_glb_in_metres(ict_morph):
    out, metrics = ict_morph
    rows = metrics["units"]["keys"]
    assert [(r["units"], r["source"]) for r in rows] == [
        ("cm", "landmarks"),
        ("mm", "landmarks"),
        ("cm", "landmarks"),
    ]
    assert [r["factor_to_working_unit"] for r in rows] == [1.0, 0.1, 1.0]
    assert all(8.5 <= r["measured"] * r["metres_per_unit"] * 100 <= 10 for r in rows)
    m = MorphGlb.load(out / "animation.glb")
    for t in (0.0, 1.0, 2.0):
        height = np.ptp(m.positions(t)[:, 1])
        assert 0.14 <= height <= 0.25, (t, height)  # an adult face, in metres
    gl = GLTF2().load(str(out / "animation.glb"))
    assert gl.nodes[0].extras["units"] == "m"
    assert gl.nodes[0].extras["metres_per_input_unit"] == 0.01


def test_identity_rest_transform_no_scale_channel_and_names(ict_morph):
    out, _ = ict_morph
    gl = GLTF2().load(str(out / "animation.glb"))
    node = gl.nodes[0]
    assert node.translation is None and node.rotation is None and node.scale is None
    assert node.matrix is None
    paths = sorted(c.target.path for c in gl.animations[0].channels)
    assert "scale" not in paths and "weights" in paths
    assert node.name == gl.meshes[0].name == "ict_generic_neutral_to_ict_generic_jawOpen"
    assert node.extras["keys"] == ["ict_generic_neutral", "smile_mm", "ict_generic_jawOpen"]
    assert node.extras["key_times"] == [0.0, 1.0, 2.0]
    names = gl.meshes[0].extras["targetNames"]
    assert names == [
        "t=0 ict_generic_neutral",
        "t=0.5",
        "t=1 smile_mm",
        "t=1.5",
        "t=2 ict_generic_jawOpen",
    ]
    f2 = GLTF2().load(str(out / "frames" / "002.glb"))
    assert f2.nodes[0].name == f2.meshes[0].name == "frame_002_smile_mm"
    assert f2.nodes[0].extras["key"] == "smile_mm" and f2.nodes[0].extras["t"] == 1.0
    assert GLTF2().load(str(out / "frames" / "001.glb")).nodes[0].name == "frame_001"


def test_every_frame_matches_its_frame_file_and_is_lit_right(ict_morph):
    out, metrics = ict_morph
    m = MorphGlb.load(out / "animation.glb")
    ft = np.asarray(metrics["frame_times"]) - metrics["frame_times"][0]
    assert 1.0 in ft  # a frame on key 1 (frame times include every key time)
    for k, t in enumerate(ft):
        fg = GLTF2().load(str(out / "frames" / f"{k:03d}.glb"))
        Pf = read_accessor(fg, fg.meshes[0].primitives[0].attributes.POSITION)
        P = m.positions(float(t))
        diag = float(np.linalg.norm(np.ptp(Pf, axis=0)))
        assert np.abs(P - Pf).max() <= 1e-6 * diag, k
        p95 = np.percentile(_angles(m.shader_normals(float(t)), _true_normals(P, m.F)), 95)
        assert p95 <= 5.0, (k, p95)
    for t in (ft[:-1] + ft[1:]) / 2:  # halfway between frames: two targets at 0.5 each
        P = m.positions(float(t))
        p95 = np.percentile(_angles(m.shader_normals(float(t)), _true_normals(P, m.F)), 95)
        assert p95 <= 5.0, (t, p95)


def test_static_normals_are_off_at_the_open_mouth(tmp_path):
    """The measurement has teeth: without NORMAL targets the open mouth is lit wrong."""
    lm = json.loads((SHARED / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": [lm] * 2}))
    paths = [SHARED / "ict_generic_neutral.obj", SHARED / "ict_generic_jawOpen.obj"]
    morph(paths, L, tmp_path / "o", frames=2, normals=False, key_metrics=False)
    m = MorphGlb.load(tmp_path / "o" / "animation.glb")
    assert all(d is None for d in m.dN)
    P = m.positions(1.0)
    assert np.percentile(_angles(m.shader_normals(1.0), _true_normals(P, m.F)), 95) > 20.0


def test_validator_clean(ict_morph):
    out, _ = ict_morph
    validate_glb([out / "animation.glb", out / "frames" / "002.glb"])


def test_three_js_plays_it_the_same(ict_morph):
    """three.js r187 (tools/gltf_three_playback.mjs, AnimationMixer in Node): identity rest
    transform, an adult face in metres, key frames on frames/NNN.glb, normals lit right."""
    out, metrics = ict_morph
    ft = np.asarray(metrics["frame_times"]) - metrics["frame_times"][0]
    got = three_playback(out / "animation.glb", ft.tolist())
    assert got["rest"] == {"position": [0, 0, 0], "quaternion": [0, 0, 0, 1], "scale": [1, 1, 1]}
    F = MorphGlb.load(out / "animation.glb").F
    for k, frame in enumerate(got["frames"]):
        P = np.asarray(frame["positions"])
        assert 0.14 <= np.ptp(P[:, 1]) <= 0.25
        fg = GLTF2().load(str(out / "frames" / f"{k:03d}.glb"))
        Pf = read_accessor(fg, fg.meshes[0].primitives[0].attributes.POSITION)
        assert np.abs(P - Pf).max() <= 1e-6 * float(np.linalg.norm(np.ptp(Pf, axis=0)))
        angles = _angles(np.asarray(frame["normals"]), _true_normals(P, F))
        assert np.percentile(angles, 95) <= 5.0


def test_rest_pose_rig_by_hand():
    """Q_k = m (s_k R_0 Va_k + t_0) from the placed frames x_k = s_k R_k Va_k + t_k, and
    the node's motion takes Q_k to m x_k; a still morph has no motion."""
    from scipy.spatial.transform import Rotation

    from conformorph.pipelines.face_morph.export import rest_pose_rig

    rng = np.random.default_rng(3)
    T, n, m = 4, 50, 0.01
    Va = rng.normal(size=(T, n, 3))
    R = np.stack([np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(T)])
    R *= np.sign(np.linalg.det(R))[:, None, None]  # rotations
    s, t = 1.0 + 0.1 * rng.random(T), rng.normal(size=(T, 3))
    X = s[:, None, None] * np.einsum("kij,knj->kni", R, Va) + t[:, None, :]
    Q, rigid = rest_pose_rig({"frames_V": X, "frame_R": R, "frame_t": t}, m)
    want = m * (s[:, None, None] * np.einsum("ij,knj->kni", R[0], Va) + t[0])
    np.testing.assert_allclose(Q, want, atol=1e-12)
    np.testing.assert_allclose(Q[0], m * X[0], atol=1e-12)  # frame 0: identity rest pose
    trans, quat = rigid
    for k in range(T):
        placed = Q[k] @ Rotation.from_quat(quat[k]).as_matrix().T + trans[k]  # x, y, z, w
        np.testing.assert_allclose(placed, m * X[k], atol=1e-12)
    still = {
        "frames_V": X[:1].repeat(2, 0),
        "frame_R": R[:1].repeat(2, 0),
        "frame_t": t[:1].repeat(2, 0),
    }
    assert rest_pose_rig(still, m)[1] is None
