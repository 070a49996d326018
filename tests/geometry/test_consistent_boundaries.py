"""Tests of conformorph.geometry.consistent_boundaries (corresponding boundary points of both shapes)."""

import numpy as np

from conformorph.geometry.boundary_anchors import boundary_anchors
from conformorph.geometry.consistent_boundaries import _consistent_arc, consistent_boundaries
from conformorph.geometry.hole_cuts import hole_cuts
from conformorph.geometry.shape_rings import validate_rings

SQ = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
#: the square with its side midpoints: a cut may end between the corner anchors
SQ8 = np.array([[0, 0], [2, 0], [4, 0], [4, 2], [4, 4], [2, 4], [0, 4], [0, 2]], dtype=float)
HOLE = np.array([[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]])
ANCHORS = np.stack([SQ, SQ], axis=1)


def _boundary(rings_s, rings_t, h=1.0):
    S, T = validate_rings(rings_s), validate_rings(rings_t)
    ba = boundary_anchors(S, T, ANCHORS)
    return S, T, consistent_boundaries(S, T, hole_cuts(S, T, ba.s_par, ba.t_par), (h, h))


def test_square_boundary_keeps_every_vertex_and_splits_evenly():
    # a target with an extra vertex mid-side: both shapes' vertices are kept
    T = np.array([[0.0, 0.0], [2.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
    S, _, b = _boundary([SQ], [T])
    assert b.n_outer == b.nb == b.n_u and b.n_hole == 0 and not b.cut_edges
    for p in SQ:
        assert np.min(np.linalg.norm(b.Bs - p, axis=1)) < 1e-12
    for p in T:
        assert np.min(np.linalg.norm(b.Bt - p, axis=1)) < 1e-12
    steps = np.linalg.norm(np.roll(b.Bs, -1, axis=0) - b.Bs, axis=1)
    assert steps.max() <= 1.0 + 1e-12
    np.testing.assert_allclose(b.Bs[b.anchor_pos], SQ[[0, 1, 2, 3]])
    assert b.segs.shape == (b.nb, 2)


def test_hole_boundary_goes_down_the_cut_round_the_hole_and_back():
    _, _, b = _boundary([SQ8, HOLE], [SQ8, HOLE])
    # the cut's two sides are the same vertices: fewer ids than entries
    assert b.n_u < b.nb and b.n_hole >= 4 and b.cut_edges
    for entries in b.copies.values():
        np.testing.assert_allclose(b.Bs[entries], b.Bs[entries[0]][None].repeat(len(entries), 0))


def test_consistent_arc_merges_nearby_parameters():
    ps = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    pt = np.array([[0.0, 0.0], [1.02, 0.0], [2.0, 0.0]])
    a, c = _consistent_arc(ps, pt, 10.0, 10.0)
    assert a.shape == c.shape == (2, 2)  # start and the one paired inner vertex
