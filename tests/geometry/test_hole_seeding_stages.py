"""Tests of the stages of conformorph.geometry.hole_seeding: seeded_hole_pairing and seed_hole."""

import numpy as np
import pytest

from conformorph.geometry.hole_seeding import seed_hole, seeded_hole_pairing
from conformorph.geometry.shape_rings import (
    HoleCorrespondenceError,
    ring_signed_area,
    validate_rings,
)

SQ = np.array([[0.0, 0.0], [6.0, 0.0], [6.0, 4.0], [0.0, 4.0]])
LEFT = np.array([[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]])
RIGHT = LEFT + [3.0, 0.0]
ANCHORS = np.stack([SQ, SQ], axis=1)


def test_holes_pair_with_the_nearest_after_the_anchor_map():
    S = validate_rings([SQ, LEFT, RIGHT])
    T = validate_rings([SQ, RIGHT, LEFT])  # the same holes listed the other way round
    hp = seeded_hole_pairing(S, T, ANCHORS)
    assert hp.few_is_source and hp.pairing == [1, 0]
    assert hp.cost.shape == (2, 2) and hp.cost[0, 1] == pytest.approx(0.0, abs=1e-9)
    assert seeded_hole_pairing(S, T, ANCHORS, pairing_rank=1).pairing == [0, 1]
    with pytest.raises(HoleCorrespondenceError, match="only 2 ways"):
        seeded_hole_pairing(S, T, ANCHORS, pairing_rank=2)


def test_fewer_holes_in_the_target():
    S = validate_rings([SQ, LEFT, RIGHT])
    T = validate_rings([SQ, RIGHT])
    hp = seeded_hole_pairing(S, T, ANCHORS)
    assert not hp.few_is_source and hp.pairing == [1]


def test_seed_hole_is_a_small_clockwise_polygon_at_the_wanted_point():
    S = validate_rings([SQ])
    ring, site, radius = seed_hole(S, np.array([3.0, 2.0]), [], seed_vertices=6)
    assert ring.shape == (6, 2) and ring_signed_area(ring) < 0
    np.testing.assert_allclose(site, [3.0, 2.0], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(ring - site, axis=1), radius)
    assert 0 < radius <= 0.02 * np.sqrt(2.0 * 24.0) + 1e-12
