import json
from pathlib import Path

import numpy as np
import pytest

from conformorph import geometry as g
from conformorph.geometry.shape_rings import validate_rings

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
SQ = np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]])
HOLE = np.array([[2.5, 1.5], [2.5, 2.5], [3.5, 2.5], [3.5, 1.5]])


def _pair(a: str, b: str):
    S = validate_rings(json.loads((SHAPES / f"{a}.json").read_text())["rings"])
    T = validate_rings(json.loads((SHAPES / f"{b}.json").read_text())["rings"])
    anchors = np.array(json.loads((SHAPES / f"anchors_{a}__{b}.json").read_text())["anchors"])
    return S, T, anchors


def test_square_by_hand():
    anchors = np.stack([SQ, SQ], axis=1)
    out = g.seed_missing_holes(validate_rings([SQ]), validate_rings([SQ, HOLE]), anchors)
    (seed,) = out.seeds
    # the hole's centroid (3, 2), mapped by the identity, has room 1 (to x = 4):
    # radius 0.3 × 1, capped at 2 % of the diagonal 4√2
    np.testing.assert_allclose(seed.centre, [3.0, 2.0])
    assert seed.radius == pytest.approx(0.02 * 4 * np.sqrt(2)) and seed.moved == 0.0
    assert (seed.side, seed.hole, seed.partner) == ("source", 0, 0)
    ring = out.source.holes[0]
    np.testing.assert_allclose(np.linalg.norm(ring - seed.centre, axis=1), seed.radius)
    assert g.ring_signed_area(ring) < 0  # clockwise, as holes are
    assert out.target is not None and len(out.target.holes) == 1


def test_letters_a_to_b_pairs_one_hole_and_seeds_the_other():
    S, T, anchors = _pair("dejavu_bold_A", "dejavu_bold_B")
    out = g.seed_missing_holes(S, T, anchors)
    assert len(out.source.holes) == len(out.target.holes) == 2
    (seed,) = out.seeds
    assert seed.side == "source"
    # the seed's ring is a valid hole of A: inside the material, crossing nothing
    again = validate_rings(list(out.source.rings))
    assert len(again.holes) == 2 and not again.fixes
    diag = float(np.linalg.norm(np.ptp(S.outer, axis=0)))
    assert 0 < seed.radius <= 0.02 * diag
    room = g.distance_to_rings(S, seed.centre[None])[0]
    assert room > 2 * seed.radius
    # A's own hole is kept and paired with one of B's
    assert any(h is S.holes[0] for h in out.source.holes)


def test_swapping_the_shapes_seeds_the_other_side():
    S, T, anchors = _pair("dejavu_bold_A", "dejavu_bold_B")
    a = g.seed_missing_holes(S, T, anchors)
    b = g.seed_missing_holes(T, S, anchors[:, ::-1])
    assert b.seeds[0].side == "target"
    assert b.seeds[0].hole == a.seeds[0].hole
    np.testing.assert_allclose(b.seeds[0].centre, a.seeds[0].centre)


def test_equal_hole_counts_only_reorder():
    S = validate_rings([SQ * 4, HOLE + [4, 8], HOLE])
    T = validate_rings([SQ * 4, HOLE, HOLE + [4, 8]])
    anchors = np.stack([SQ * 4, SQ * 4], axis=1)
    out = g.seed_missing_holes(S, T, anchors)
    assert out.seeds == ()
    # source hole 1 sits where target hole 0 is, and is moved to slot 0
    np.testing.assert_array_equal(out.source.holes[0], S.holes[1])
    assert out.target is T


def test_invariant_to_a_similarity_of_both_shapes():
    anchors = np.stack([SQ, SQ], axis=1)
    base = g.seed_missing_holes(validate_rings([SQ]), validate_rings([SQ, HOLE]), anchors)
    c, s = np.cos(0.7), np.sin(0.7)
    R = 1e3 * np.array([[c, -s], [s, c]])
    moved = g.seed_missing_holes(
        validate_rings([SQ @ R.T]), validate_rings([SQ @ R.T, HOLE @ R.T]), anchors @ R.T
    )
    np.testing.assert_allclose(moved.seeds[0].centre, base.seeds[0].centre @ R.T, atol=1e-6)
    assert moved.seeds[0].radius == pytest.approx(1e3 * base.seeds[0].radius)


def test_bad_inputs():
    S, T = validate_rings([SQ]), validate_rings([SQ, HOLE])
    with pytest.raises(ValueError, match="anchors"):
        g.seed_missing_holes(S, T, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="seed_vertices"):
        g.seed_missing_holes(S, T, np.stack([SQ, SQ], axis=1), seed_vertices=2)


def test_pairings_by_rank():
    S, T, anchors = _pair("dejavu_bold_A", "dejavu_bold_B")
    first = g.seed_missing_holes(S, T, anchors)
    second = g.seed_missing_holes(S, T, anchors, pairing_rank=1)
    # A's one hole goes with the other of B's two holes; the seed takes the rest
    assert first.seeds[0].hole != second.seeds[0].hole
    with pytest.raises(g.HoleCorrespondenceError, match="only 2 ways"):
        g.seed_missing_holes(S, T, anchors, pairing_rank=2)
    with pytest.raises(ValueError, match="pairing_rank"):
        g.seed_missing_holes(S, T, anchors, pairing_rank=-1)
