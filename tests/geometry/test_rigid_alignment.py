import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conformorph.geometry.rigid_alignment import (
    RigidAlignmentOptions,
    SimilarityTransform,
    normalize_by_diameter,
    rigid_landmark_alignment,
    surface_diameter,
    umeyama_alignment,
)


def _cloud(n=40, seed=0):
    return np.random.default_rng(seed).normal(size=(n, 3)) * [3.0, 2.0, 1.0]


def test_hand_worked_diameter_and_normalisation():
    V = np.array([[0.0, 0, 0], [3, 0, 0], [0, 4, 0], [1, 1, 1]])
    assert surface_diameter(V) == 5.0
    Vn, T = normalize_by_diameter(V)
    assert abs(surface_diameter(Vn) - 1.0) < 1e-15
    np.testing.assert_allclose(Vn.mean(axis=0), 0, atol=1e-15)
    np.testing.assert_allclose(T.apply(Vn), V, atol=1e-14)


def test_diameter_matches_brute_force():
    V = _cloud(300, 1)
    brute = np.linalg.norm(V[:, None] - V[None], axis=2).max()
    assert abs(surface_diameter(V) - brute) < 1e-12


def test_umeyama_recovers_similarity():
    X = _cloud()
    R = Rotation.from_rotvec([0.3, -1.2, 0.5]).as_matrix()
    Y = 2.5 * X @ R.T + [1.0, -2.0, 30.0]
    T = umeyama_alignment(X, Y)
    np.testing.assert_allclose(T.rotation, R, atol=1e-12)
    assert abs(T.scale - 2.5) < 1e-12
    np.testing.assert_allclose(T.apply(X), Y, atol=1e-10)
    # without scale: Kabsch, still the right rotation
    T2 = umeyama_alignment(X, X @ R.T + 1.0, with_scale=False)
    assert T2.scale == 1.0
    np.testing.assert_allclose(T2.rotation, R, atol=1e-12)
    assert np.linalg.det(T2.rotation) > 0


def test_reflection_never_returned():
    X = _cloud()
    Y = X * [1.0, 1.0, -1.0]
    T = umeyama_alignment(X, Y, with_scale=False)
    assert abs(np.linalg.det(T.rotation) - 1.0) < 1e-12


def test_transform_algebra():
    T = SimilarityTransform(
        Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix(), np.array([1.0, 2, 3]), 2.0
    )
    X = _cloud(5)
    np.testing.assert_allclose(T.inverse().apply(T.apply(X)), X, atol=1e-12)
    np.testing.assert_allclose(T.compose(T.inverse()).apply(X), X, atol=1e-12)


def test_trimmed_alignment_ignores_moving_landmarks():
    X = _cloud(30, 2)
    R = Rotation.from_rotvec([0.0, 0.4, 0.1]).as_matrix()
    Y = X @ R.T + [5.0, 0, 0]
    Y[:6] += np.random.default_rng(3).normal(0, 1.0, (6, 3))  # "expression" landmarks
    T, info = rigid_landmark_alignment(X, Y)
    np.testing.assert_allclose(T.rotation, R, atol=1e-10)
    assert not info.rigid[:6].any() and info.rigid[6:].all()
    assert info.rms_rigid < 1e-10 < info.rms_all
    # order of the landmarks does not matter
    perm = np.random.default_rng(4).permutation(30)
    T2, info2 = rigid_landmark_alignment(X[perm], Y[perm])
    np.testing.assert_allclose(T2.rotation, T.rotation, atol=1e-10)


def test_icp_refinement_on_surface():
    # surface: a bumpy height field; landmarks perturbed, ICP on the surface fixes the pose
    g = np.linspace(-1, 1, 40)
    x, y = np.meshgrid(g, g)
    S = np.c_[x.ravel(), y.ravel(), 0.3 * np.exp(-4 * (x**2 + y**2)).ravel() + 0.1 * x.ravel() ** 2]
    R = Rotation.from_rotvec([0.05, -0.08, 0.1]).as_matrix()
    Tgt = S @ R.T + [0.02, 0.01, -0.03]
    idx = np.array([0, 39, 1560, 1599, 820, 300, 1200])
    noise = np.random.default_rng(5).normal(0, 0.01, (7, 3))
    T0, info0 = rigid_landmark_alignment(S[idx], Tgt[idx] + noise)
    T1, info1 = rigid_landmark_alignment(
        S[idx],
        Tgt[idx] + noise,
        source_surface=S,
        target_surface=Tgt,
        options=RigidAlignmentOptions(icp_iterations=30, icp_radius=2.0),
    )
    e0 = np.linalg.norm(T0.apply(S) - Tgt, axis=1).mean()
    e1 = np.linalg.norm(T1.apply(S) - Tgt, axis=1).mean()
    assert info1.icp_iterations > 0 and e1 < e0


def test_icp_gives_the_same_pose_on_any_number_of_kdtree_workers(monkeypatch):
    import importlib

    ra = importlib.import_module("conformorph.geometry.rigid_alignment")
    g = np.linspace(-1, 1, 40)
    x, y = np.meshgrid(g, g)
    S = np.c_[x.ravel(), y.ravel(), 0.2 * np.sin(3 * x).ravel() * y.ravel()]
    Tgt = S @ Rotation.from_rotvec([0.1, 0.05, -0.07]).as_matrix().T + 0.01
    idx = np.array([0, 39, 1560, 1599, 820])
    poses = []
    for threads in (1, 2):
        monkeypatch.setattr(ra, "available_threads", lambda n=threads: n)
        T, info = rigid_landmark_alignment(
            S[idx],
            Tgt[idx] + 0.01,
            source_surface=S,
            target_surface=Tgt,
            options=RigidAlignmentOptions(icp_iterations=10, icp_radius=2.0),
        )
        assert info.icp_iterations > 0
        poses.append((T.rotation, T.translation, info.icp_rms))
    np.testing.assert_array_equal(poses[0][0], poses[1][0])
    np.testing.assert_array_equal(poses[0][1], poses[1][1])
    assert poses[0][2] == poses[1][2]


def test_validation_and_no_mutation():
    X = _cloud(5)
    X0 = X.copy()
    umeyama_alignment(X, X + 1)
    np.testing.assert_array_equal(X, X0)
    with pytest.raises(ValueError):
        umeyama_alignment(X[:2], X[:2])
    with pytest.raises(ValueError):
        rigid_landmark_alignment(X, X[:4])
    with pytest.raises(ValueError):
        surface_diameter(np.full((3, 3), np.nan))
    with pytest.raises(ValueError):
        rigid_landmark_alignment(X, X, options=RigidAlignmentOptions(icp_iterations=3))


def test_options_defaults_and_with_scale_recovers_a_known_similarity():
    o = RigidAlignmentOptions()
    assert (o.with_scale, o.trim_factor, o.min_rigid_fraction, o.max_iterations) == (
        False,
        2.0,
        0.3,
        20,
    )
    assert (o.icp_iterations, o.icp_radius, o.icp_trim) == (0, 0.1, 0.8)
    X = np.random.default_rng(3).normal(size=(8, 3))
    R = Rotation.from_rotvec([0.3, -0.2, 0.9]).as_matrix()
    Y = 1.7 * X @ R.T + [0.5, -1.0, 2.0]
    T, info = rigid_landmark_alignment(X, Y, options=RigidAlignmentOptions(with_scale=True))
    np.testing.assert_allclose(T.rotation, R, atol=1e-10)
    assert abs(T.scale - 1.7) < 1e-10 and info.rms_all < 1e-10
    T1, _ = rigid_landmark_alignment(X, Y)  # default: no scale
    assert T1.scale == 1.0
