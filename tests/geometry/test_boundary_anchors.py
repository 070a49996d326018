"""Tests of conformorph.geometry.boundary_anchors (feature points on the outer boundaries)."""

import numpy as np
import pytest

from conformorph.geometry.boundary_anchors import _project_on_ring, boundary_anchors
from conformorph.geometry.shape_rings import (
    AnchorOutsideShapeError,
    ShapeError,
    TooFewAnchorsError,
    validate_rings,
)

SQ = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])


def test_project_on_ring_by_hand():
    s, q, d = _project_on_ring(SQ, np.array([2.0, -1.0]))
    assert s == pytest.approx(2.0) and d == pytest.approx(1.0)
    np.testing.assert_allclose(q, [2.0, 0.0])
    # within the snap distance of a corner: onto the corner
    s, q, _ = _project_on_ring(SQ, np.array([4.0 - 1e-4, 0.0]))
    assert s == pytest.approx(4.0) and q.tolist() == [4.0, 0.0]


def test_boundary_and_inner_anchors_sorted_along_the_source():
    S = validate_rings([SQ])
    T = validate_rings([2.0 * SQ])
    anchors = np.array(
        [[[4, 4], [8, 8]], [[1, 1], [3, 3]], [[0, 0], [0, 0]], [[2, 0], [4, 0]]], float
    )
    ba = boundary_anchors(S, T, anchors)
    assert ba.bidx.tolist() == [2, 3, 0] and ba.inner.tolist() == [1]
    np.testing.assert_allclose(ba.s_par, [0.0, 2.0, 8.0])
    np.testing.assert_allclose(ba.t_par, 2.0 * ba.s_par)


def test_bad_anchors():
    S = validate_rings([SQ])
    with pytest.raises(AnchorOutsideShapeError):
        boundary_anchors(S, S, np.array([[[9.0, 9.0], [1.0, 1.0]]]))
    with pytest.raises(TooFewAnchorsError):
        boundary_anchors(S, S, np.array([[[1.0, 1.0], [1.0, 1.0]]]))
    with pytest.raises(ShapeError, match="boundary of one shape"):
        boundary_anchors(S, S, np.array([[[0.0, 0.0], [1.0, 1.0]]]))
    # three corners in opposite orders
    with pytest.raises(ShapeError, match="orders"):
        boundary_anchors(
            S, S, np.array([[[0, 0], [0, 0]], [[4, 0], [4, 4]], [[4, 4], [4, 0]]], float)
        )
    with pytest.raises(ValueError, match="shape"):
        boundary_anchors(S, S, np.zeros((2, 2)))
