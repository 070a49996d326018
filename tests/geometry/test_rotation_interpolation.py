import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conformorph.geometry.rigid_alignment import SimilarityTransform
from conformorph.geometry.rotation_interpolation import (
    interpolate_rotations,
    interpolate_similarity,
    rotation_to_quaternion_xyzw,
)


def test_hand_worked_slerp_of_two_keys():
    Rs = Rotation.from_rotvec([[0, 0, 0], [0, 0, np.pi / 2]]).as_matrix()
    R = interpolate_rotations(np.array([0.0, 1.0]), Rs, np.array([0.5, 2.0]))
    np.testing.assert_allclose(
        R[0], Rotation.from_rotvec([0, 0, np.pi / 4]).as_matrix(), atol=1e-12
    )
    # extrapolation continues at the same angular velocity
    np.testing.assert_allclose(R[1], Rotation.from_rotvec([0, 0, np.pi]).as_matrix(), atol=1e-9)


def test_keys_reproduced_and_stays_on_so3():
    t = np.array([0.0, 1.0, 2.0, 3.5])
    keys = Rotation.random(4, random_state=1).as_matrix()
    te = np.linspace(-1, 4.5, 57)
    R = interpolate_rotations(t, keys, te)
    np.testing.assert_allclose(
        np.einsum("tij,tkj->tik", R, R), np.broadcast_to(np.eye(3), R.shape), atol=1e-12
    )
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    np.testing.assert_allclose(interpolate_rotations(t, keys, t), keys, atol=1e-10)
    # continuity at the ends (interpolated and extrapolated pieces meet)
    e = 1e-7
    Rb = interpolate_rotations(t, keys, np.array([t[-1] - e, t[-1] + e]))
    assert np.abs(Rb[0] - Rb[1]).max() < 1e-5


def test_invariant_to_a_common_rotation():
    t = np.array([0.0, 1.0, 2.0])
    keys = Rotation.random(3, random_state=2).as_matrix()
    G = Rotation.from_rotvec([0.3, 0.2, -0.1]).as_matrix()
    te = np.array([0.3, 1.5, 2.5])
    R1 = interpolate_rotations(t, keys, te)
    R2 = interpolate_rotations(t, G[None] @ keys, te)
    np.testing.assert_allclose(R2, G[None] @ R1, atol=1e-10)


def test_similarity_interpolation():
    T0 = SimilarityTransform(np.eye(3), np.zeros(3), 1.0)
    T1 = SimilarityTransform(
        Rotation.from_rotvec([0, np.pi / 3, 0]).as_matrix(), np.array([2.0, 0, 0]), 4.0
    )
    out = interpolate_similarity(np.array([0.0, 1.0]), [T0, T1], np.array([0.0, 0.5, 1.0]))
    assert out[1].scale == pytest.approx(2.0)  # geometric mean: log-scale is interpolated
    np.testing.assert_allclose(out[1].translation, [1.0, 0, 0])
    np.testing.assert_allclose(out[2].rotation, T1.rotation, atol=1e-12)
    q = rotation_to_quaternion_xyzw(out[1].rotation)
    np.testing.assert_allclose(q, [0, np.sin(np.pi / 12), 0, np.cos(np.pi / 12)], atol=1e-12)
    with pytest.raises(ValueError):
        interpolate_similarity(np.array([0.0, 1.0]), [T0], np.array([0.5]))


def test_validation_and_no_mutation():
    keys = Rotation.random(2, random_state=3).as_matrix()
    k0 = keys.copy()
    interpolate_rotations(np.array([0.0, 1.0]), keys, np.array([0.5]))
    np.testing.assert_array_equal(keys, k0)
    with pytest.raises(ValueError):
        interpolate_rotations(np.array([0.0, 1.0]), 2 * keys, np.array([0.5]))
    with pytest.raises(ValueError):
        interpolate_rotations(np.array([1.0, 0.0]), keys, np.array([0.5]))
