"""Tests of conformorph.geometry.arap_interpolation (Alexa et al. 2000 baseline)."""

import numpy as np
import pytest

from conformorph.geometry.arap_interpolation import arap_interpolation
from conformorph.geometry.green_lagrange_strain import signed_areas


def square() -> tuple[np.ndarray, np.ndarray]:
    V = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]])
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    return V, F


def rot(th: float) -> np.ndarray:
    return np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])


def test_hand_worked_rotation_is_interpolated_by_angle():
    # A rigid rotation by 90° about the centre vertex: ARAP rotates by t·90°,
    # keeping the square's area, where linear blending shrinks it to 1/2.
    V, F = square()
    c = V[4]
    T = (V - c) @ rot(np.pi / 2).T + c
    frames = arap_interpolation(V, T, F, [0.0, 0.5, 1.0], fixed_vertex=4)
    assert np.allclose(frames[1], (V - c) @ rot(np.pi / 4).T + c, atol=1e-12)
    assert np.allclose(frames[0], V) and np.allclose(frames[2], T)


def test_areas_stay_positive_for_large_rotation_and_stretch():
    V, F = square()
    T = (V * [2.0, 0.5]) @ rot(2.5).T
    frames = arap_interpolation(V, T, F, np.linspace(0, 1, 11))
    for X in frames:
        assert np.all(signed_areas(X, F) > 0)


def test_rigid_motion_and_scale_invariance():
    V, F = square()
    T = V * [1.5, 1.0] + [0.2, 0.1]
    times = np.linspace(0, 1, 5)
    base = arap_interpolation(V, T, F, times)
    for s in (1e-8, 1e8):
        R = rot(0.3)
        moved = arap_interpolation(s * V @ R.T, s * T @ R.T, F, times)
        assert np.allclose(moved, s * base @ R.T, atol=1e-9 * s)


def test_reordering():
    V, F = square()
    T = V**2
    perm = np.array([4, 2, 0, 3, 1])
    inv = np.argsort(perm)
    a = arap_interpolation(V, T, F, [0.3, 0.7], fixed_vertex=4)
    b = arap_interpolation(V[perm], T[perm], inv[F], [0.3, 0.7], fixed_vertex=int(inv[4]))
    assert np.allclose(b, a[:, perm], atol=1e-12)


def test_validation_and_no_mutation():
    V, F = square()
    T = V.copy()
    T[:, 0] *= -1
    with pytest.raises(ValueError):
        arap_interpolation(V, T, F, [0.5])
    with pytest.raises(ValueError):
        arap_interpolation(V, V[:3], F, [0.5])
    with pytest.raises(ValueError):
        arap_interpolation(V, V, F, [0.5], fixed_vertex=9)
    c = V.copy(), F.copy()
    arap_interpolation(V, V * 2, F, [0.5])
    assert np.array_equal(V, c[0]) and np.array_equal(F, c[1])
