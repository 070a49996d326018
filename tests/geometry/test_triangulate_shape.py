"""Tests of geometry.triangulate_shape."""

import numpy as np
import pytest

from geometry.green_lagrange_strain import signed_areas
from geometry.shape_rings import validate_rings
from geometry.triangulate_shape import triangulate_polygon, triangulate_shape

SQUARE = np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]])
HOLE = np.array([[1.0, 1], [1, 3], [3, 3], [3, 1]])


def test_hand_worked_square_without_steiner_points():
    V, F = triangulate_polygon(SQUARE)
    assert np.array_equal(V, SQUARE) and F.shape == (2, 3)
    assert np.all(signed_areas(V, F) > 0) and signed_areas(V, F).sum() == pytest.approx(16.0)


def _dense(ring: np.ndarray, k: int) -> np.ndarray:
    u = np.arange(k)[:, None] / k
    return np.vstack(
        [a + u * (b - a) for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True)]
    )


def test_hole_removed_rings_first_and_area_preserved():
    s = validate_rings([_dense(SQUARE, 8), _dense(HOLE, 4)])
    V, F = triangulate_shape(s, max_area=0.2, min_angle=20)
    assert np.array_equal(V[:32], s.outer) and np.array_equal(V[32:48], s.holes[0])
    A = signed_areas(V, F)
    assert np.all(A > 0) and A.sum() == pytest.approx(12.0)
    assert A.max() <= 0.2 + 1e-12
    used = np.zeros(V.shape[0], bool)
    used[F.ravel()] = True
    assert used.all()


def test_invariance_under_scaling():
    for scale in (1e-8, 1e8):
        V, F = triangulate_polygon(scale * SQUARE, max_area=scale**2 * 1.0)
        assert signed_areas(V, F).sum() == pytest.approx(16 * scale**2)


def test_no_mutation():
    a = SQUARE.copy()
    triangulate_polygon(a, max_area=1.0)
    assert np.array_equal(a, SQUARE)
