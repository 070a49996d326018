"""Tests of conformorph.geometry.hole_cuts (pairing the holes and cutting them to the outer ring)."""

import numpy as np
import pytest

from conformorph.geometry.boundary_anchors import boundary_anchors
from conformorph.geometry.hole_cuts import check_hole_counts, hole_cuts
from conformorph.geometry.shape_rings import HoleCorrespondenceError, validate_rings

SQ = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])
#: the square with its side midpoints: a cut may end between the corner anchors
SQ8 = np.array([[0, 0], [2, 0], [4, 0], [4, 2], [4, 4], [2, 4], [0, 4], [0, 2]], dtype=float)
HOLE = np.array([[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]])
ANCHORS = np.stack([SQ, SQ], axis=1)


def test_one_cut_per_hole_between_the_corners():
    S = validate_rings([SQ8, HOLE])
    ba = boundary_anchors(S, S, ANCHORS)
    cuts = hole_cuts(S, S, ba.s_par, ba.t_par)
    assert cuts.hole_match == [0] and len(cuts.cuts) == 1
    (ps, qs, s_s), (pt, qt, s_t) = cuts.cuts[0]
    # the same shape: the same cut, a shortest one (a side midpoint to the nearest hole corner)
    assert (ps, qs, s_s) == (pt, qt, s_t)
    assert np.linalg.norm(S.outer[ps] - S.holes[0][qs]) == pytest.approx(1.0)
    kinds = [c[0] for c in cuts.corners]
    assert kinds.count("a") == 4 and kinds.count("c") == 1
    rel = [(c[2] - ba.s_par[0]) % 16.0 for c in cuts.corners]
    assert rel == sorted(rel)


def test_no_holes_no_cuts_and_bad_pairings():
    S = validate_rings([SQ])
    ba = boundary_anchors(S, S, ANCHORS)
    cuts = hole_cuts(S, S, ba.s_par, ba.t_par)
    assert cuts.cuts == [] and len(cuts.corners) == 4
    H = validate_rings([SQ8, HOLE])
    with pytest.raises(ValueError, match="permutation"):
        hole_cuts(H, H, ba.s_par, ba.t_par, hole_match=[1])
    with pytest.raises(HoleCorrespondenceError, match="0 hole"):
        check_hole_counts(S, H)
    check_hole_counts(H, H)
