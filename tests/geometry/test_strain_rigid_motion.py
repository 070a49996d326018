"""Tests of conformorph.geometry.strain_rigid_motion (the strain morph's steps 1 and 5)."""

import numpy as np
import pytest

from conformorph.geometry.strain_rigid_motion import (
    gauge_vertices,
    restore_rigid_motion,
    rigid_motion,
    to_gauge,
    wrap_angle,
)

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
F = np.array([[0, 1, 2], [0, 2, 3]])


def _rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def test_wrap_angle_range():
    assert wrap_angle(np.pi) == np.pi and wrap_angle(-np.pi) == np.pi
    assert wrap_angle(3 * np.pi / 2) == pytest.approx(-np.pi / 2)
    assert wrap_angle(0.25) == 0.25


def test_rigid_motion_of_a_moved_copy_is_that_motion():
    theta, shift = 0.7, np.array([3.0, -2.0])
    target = SQUARE @ _rot(theta).T + shift
    ref = np.array([[0.5, 0.25], [0.75, 0.5]])
    m = rigid_motion(SQUARE, target, F, ref)
    assert m.rotation == pytest.approx(theta)
    np.testing.assert_allclose(m.A0, ref[0])
    # T carries A0 to its image
    np.testing.assert_allclose(m.A0 + m.translation, ref[0] @ _rot(theta).T + shift)
    np.testing.assert_allclose(m.follow(target), ref @ _rot(theta).T + shift, atol=1e-12)


def test_rigid_motion_rejects_bad_reference_points():
    with pytest.raises(ValueError, match="inside"):
        rigid_motion(SQUARE, SQUARE, F, np.array([[5.0, 5.0], [0.5, 0.5]]))
    with pytest.raises(ValueError, match="coincide"):
        rigid_motion(SQUARE, SQUARE, F, np.array([[0.5, 0.5], [0.5, 0.5]]))
    with pytest.raises(ValueError, match="shape"):
        rigid_motion(SQUARE, SQUARE, F, np.zeros(4))


def test_gauge_puts_a_at_the_origin_and_b_on_the_x_axis():
    X = SQUARE @ _rot(1.1).T + 7.0
    a, b = gauge_vertices(X, X[0] + 0.01)
    assert a == 0 and b == 2  # b: the vertex farthest from a
    G = to_gauge(X, a, b)
    np.testing.assert_allclose(G[a], 0.0, atol=1e-12)
    assert abs(G[b, 1]) < 1e-12 and G[b, 0] > 0
    # a rigid motion: distances kept
    np.testing.assert_allclose(np.linalg.norm(G[1] - G[3]), np.sqrt(2.0))


def test_restore_rigid_motion_interpolates_rotation_and_translation():
    theta, shift = 0.6, np.array([1.0, 2.0])
    target = SQUARE @ _rot(theta).T + shift
    ref = np.array([[0.5, 0.25], [0.75, 0.5]])
    m = rigid_motion(SQUARE, target, F, ref)
    G = to_gauge(SQUARE, *gauge_vertices(SQUARE, m.A0))
    times = np.array([0.0, 0.5, 1.0])
    frames = restore_rigid_motion(np.stack([G] * 3), times, m)
    np.testing.assert_allclose(frames[0], SQUARE, atol=1e-12)
    np.testing.assert_allclose(frames[2], target, atol=1e-12)
    half = (SQUARE - ref[0]) @ _rot(theta / 2).T + ref[0] + 0.5 * m.translation
    np.testing.assert_allclose(frames[1], half, atol=1e-12)
