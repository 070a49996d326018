"""Tests of geometry.shape_rings."""

import numpy as np
import pytest

from geometry.shape_rings import (
    SelfIntersectingRingError,
    ShapeError,
    points_in_shape,
    ring_signed_area,
    validate_rings,
)

SQUARE = np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]])
HOLE = np.array([[1.0, 1], [1, 3], [3, 3], [3, 1]])  # clockwise


def test_hand_worked_area_and_orientation_fix_reported():
    assert ring_signed_area(SQUARE) == 16.0
    s = validate_rings([SQUARE[::-1], HOLE[::-1]])
    assert ring_signed_area(s.outer) == 16.0 and ring_signed_area(s.holes[0]) == -4.0
    assert s.area == 12.0
    assert any("outer ring: orientation reversed" in f for f in s.fixes)
    assert any("hole 1: orientation reversed" in f for f in s.fixes)
    assert validate_rings([SQUARE, HOLE]).fixes == ()


def test_closing_point_dropped():
    s = validate_rings([np.vstack([SQUARE, SQUARE[:1]])])
    assert s.outer.shape == (4, 2) and s.fixes


def test_self_intersections_and_bad_holes_are_named():
    bowtie = np.array([[0.0, 0], [2, 2], [2, 0], [0, 2]])
    with pytest.raises(SelfIntersectingRingError, match="intersects itself"):
        validate_rings([bowtie])
    with pytest.raises(SelfIntersectingRingError, match="outside"):
        validate_rings([SQUARE, HOLE + 10])
    with pytest.raises(SelfIntersectingRingError, match="intersect"):
        validate_rings([SQUARE, HOLE + [2.5, 0]])
    with pytest.raises(ShapeError):
        validate_rings([SQUARE[:2]])
    with pytest.raises(ShapeError):
        validate_rings([])


def test_points_in_shape_with_hole_and_boundary():
    s = validate_rings([SQUARE, HOLE])
    P = np.array([[0.5, 0.5], [2.0, 2.0], [5.0, 1.0], [4.0, 2.0], [1.0, 2.0]])
    assert points_in_shape(s, P).tolist() == [True, False, False, True, True]


@pytest.mark.parametrize("scale", [1e-8, 1e8])
def test_scale_and_rotation_invariance(scale):
    th = 0.3
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    s = validate_rings([scale * SQUARE @ R.T, scale * HOLE @ R.T])
    P = scale * np.array([[0.5, 0.5], [2.0, 2.0]]) @ R.T
    assert points_in_shape(s, P).tolist() == [True, False]
    assert s.area == pytest.approx(12 * scale**2)


def test_inputs_not_mutated():
    a, h = SQUARE[::-1].copy(), HOLE.copy()
    c = a.copy(), h.copy()
    validate_rings([a, h])
    assert np.array_equal(a, c[0]) and np.array_equal(h, c[1])
