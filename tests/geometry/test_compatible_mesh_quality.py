"""Tests of geometry.compatible_mesh_quality (minimum angles, sliver collapse, quality flips)."""

import numpy as np
import pytest

from geometry.compatible_mesh_quality import collapse_slivers, improve_quality, min_triangle_angle
from geometry.flip_repair import _areas

V = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.3, 0.2]])
F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
FIXED = np.array([True, True, True, True, False])


def test_min_triangle_angle_by_hand():
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    assert min_triangle_angle(tri, np.array([[0, 1, 2]])) == pytest.approx(45.0)


def test_improve_quality_raises_the_minimum_angle_and_keeps_orientation():
    Xs, Xt = V.copy(), 2.0 * V
    before = min(min_triangle_angle(Xs, F), min_triangle_angle(Xt, F))
    F2 = improve_quality(Xs, Xt, F, FIXED, 3)
    after = min(min_triangle_angle(Xs, F2), min_triangle_angle(Xt, F2))
    assert after > before
    assert np.all(_areas(Xs, F2) > 0) and np.all(_areas(Xt, F2) > 0)
    np.testing.assert_array_equal(Xs[:4], V[:4])  # fixed vertices stay


def test_collapse_slivers_drops_a_vertex_and_reports_the_kept_ids():
    # a free vertex almost on the diagonal's end: collapsing it onto a corner helps
    W = V.copy()
    W[4] = [0.05, 0.04]
    Xs, Xt, F2, fixed, ids, collapsed = collapse_slivers(W, 2.0 * W, F, FIXED)
    assert collapsed == 1 and ids.tolist() == [0, 1, 2, 3]
    assert F2.shape[0] == 2 and fixed.all()
    assert np.all(_areas(Xs, F2) > 0) and np.all(_areas(Xt, F2) > 0)
