"""Tests of conformorph.geometry.triangulate_shape."""

import numpy as np
import pytest

from conformorph.geometry.green_lagrange_strain import signed_areas
from conformorph.geometry.shape_rings import validate_rings
from conformorph.geometry.triangulate_shape import triangulate_polygon, triangulate_shape

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


def test_triangulate_segments_keeps_inner_segment_when_asked():
    from conformorph.geometry.triangulate_shape import triangulate_segments

    sq = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]])
    segs = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [0, 4]])
    V, F = triangulate_segments(sq, segs, max_area=0.01, min_angle=20, split_inner_segments=False)
    E = {tuple(sorted((int(f[k]), int(f[(k + 1) % 3])))) for f in F for k in range(3)}
    assert (0, 4) in E  # the inner segment stays one edge
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    area = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert np.all(area > 0) and area.sum() == pytest.approx(1.0)
    np.testing.assert_array_equal(V[:5], sq)


def test_triangulate_segments_hole_marker_and_crossings():
    from conformorph.geometry.triangulate_shape import triangulate_segments

    outer = np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]])
    hole = np.array([[1.0, 1], [1, 3], [3, 3], [3, 1]])
    segs = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4]])
    V, F = triangulate_segments(np.vstack([outer, hole]), segs, hole_points=np.array([[2.0, 2.0]]))
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    assert 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() == pytest.approx(12.0)
    # two crossing inner segments get their crossing as a vertex
    X = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2], [0.5, 0.5], [1.5, 1.5], [0.5, 1.5], [1.5, 0.5]])
    s2 = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [6, 7]])
    V, _ = triangulate_segments(X, s2)
    assert np.min(np.linalg.norm(V - [1.0, 1.0], axis=1)) < 1e-12


def test_point_inside_ring_of_a_concave_ring():
    from conformorph.geometry.shape_rings import points_in_ring
    from conformorph.geometry.triangulate_shape import point_inside_ring

    L = np.array([[0.0, 0], [3, 0], [3, 1], [1, 1], [1, 3], [0, 3]])
    for ring in (L, L[::-1]):
        p = point_inside_ring(ring)
        assert points_in_ring(L, p[None])[0]


def test_a_repeated_vertex_joins_its_first_copy():
    """A unit square whose corner 2 is given twice (vertices 2 and 3 equal, joined by a
    zero-length segment): the square is triangulated as if the corner were given once,
    the repeat stays in the output in no triangle (Triangle's behaviour on a segment
    naming an ignored repeat is undefined: it crashed the process in some runs)."""
    from conformorph.geometry.triangulate_shape import triangulate_segments

    V = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 1.0], [0.0, 1.0]])
    S = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [4, 0]])
    for _ in range(20):  # the crash was intermittent
        W, F = triangulate_segments(V, S)
        assert np.array_equal(W[:5], V)
        assert 3 not in F
        e1, e2 = W[F[:, 1]] - W[F[:, 0]], W[F[:, 2]] - W[F[:, 0]]
        assert np.isclose((e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() / 2, 1.0)
    W, F = triangulate_segments(np.delete(V, 3, 0), np.array([[0, 1], [1, 2], [2, 3], [3, 0]]))
    assert W.shape == (4, 2) and F.shape == (2, 3)  # distinct vertices: as before
