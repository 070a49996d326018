"""conformorph.geometry.outline_correspondence: automatic corresponding points of two outlines."""

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.geometry.outline_correspondence import MatchOptions, match_outlines

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
FREE = MatchOptions(rotation_weight=0.0)  # no upright prior: rotation-invariant


def _outer(name: str) -> np.ndarray:
    return np.array(json.loads((SHAPES / f"{name}.json").read_text())["rings"][0], dtype=float)


def _rot(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def _pairs(m) -> set[tuple[int, int]]:
    return set(zip(m.source_index.tolist(), m.target_index.tolist(), strict=True))


def test_rectangle_onto_itself_turned_a_half_by_hand():
    """A 2 x 1 rectangle against itself turned by pi, started at its third corner.

    The turned copy's vertex j is the original's vertex (j + 2) % 4 moved to
    the opposite corner; the rigid part (a half turn) is removed, so every
    corner is matched to the corner it became: i <-> (i + 2) % 4 shifted by the
    new start, i.e. target index i.
    """
    rect = np.array([[0, 0], [2, 0], [2, 1], [0, 1]], dtype=float)
    turned = np.roll(rect @ _rot(np.pi).T + [5, 5], -2, axis=0)  # turned[j] = R rect[j + 2]
    m = match_outlines(rect, turned, options=FREE)
    assert _pairs(m) == {(0, 2), (1, 3), (2, 0), (3, 1)}
    assert abs(m.rotation) == pytest.approx(np.pi)
    assert m.procrustes_rms == pytest.approx(0, abs=1e-12)
    assert set(m.origin) == {"feature"}
    np.testing.assert_allclose(m.source_points, rect[m.source_index])
    np.testing.assert_allclose(m.target_points, turned[m.target_index])


@pytest.mark.parametrize(
    "name", ["dejavu_bold_C", "figure_stand", "dejavu_bold_S", "dejavu_bold_L"]
)
def test_a_moved_copy_is_matched_vertex_to_vertex(name):
    """Rotation, scale, start vertex and direction of the target: each pair is (i, image of i)."""
    ring = _outer(name)
    n = len(ring)
    k = 7 % n
    for angle, scale, reverse in [(0.0, 1.0, False), (2.0, 1e-8, False), (-1.0, 1e8, True)]:
        moved = scale * ring @ _rot(angle).T + [1.0, 2.0]
        order = np.roll(np.arange(n), -k)  # moved vertex j is ring vertex order[j]
        if reverse:
            order = order[::-1]
        m = match_outlines(ring, moved[order], options=FREE)
        inverse = np.argsort(order)
        assert len(m.origin) >= 3
        assert all(int(inverse[i]) == j for i, j in _pairs(m)), (angle, scale, reverse)
        assert np.angle(np.exp(1j * (m.rotation - angle))) == pytest.approx(0, abs=1e-6)


@pytest.mark.parametrize(
    ("a", "b"), [("dejavu_bold_C", "dejavu_bold_U"), ("figure_stand", "figure_jump")]
)
def test_matching_two_shapes_is_invariant(a, b):
    """Moving, rescaling, restarting or reversing the target changes no pair (mapped back)."""
    src, tgt = _outer(a), _outer(b)
    n = len(tgt)
    for options in (FREE, MatchOptions()):
        base = _pairs(match_outlines(src, tgt, options=options))
        for angle, scale, k, reverse in [(0.0, 1e8, 5, False), (0.0, 1e-8, 0, True)] + (
            [(1.3, 2.0, 11, True)] if options is FREE else []
        ):
            order = np.roll(np.arange(n), -k)
            if reverse:
                order = order[::-1]
            moved = (scale * tgt @ _rot(angle).T)[order]
            m = match_outlines(src, moved, options=options)
            assert {(i, int(order[j])) for i, j in _pairs(m)} == base


def test_upright_prior_prefers_small_rotations():
    m = match_outlines(_outer("dejavu_bold_I"), _outer("dejavu_bold_L"))
    assert abs(m.rotation) < np.pi / 4


def test_pairs_follow_both_rings_in_the_same_cyclic_order():
    src, tgt = _outer("flubber_horse"), _outer("flubber_star")
    m = match_outlines(src, tgt)
    order = np.argsort(m.source_index)
    t = m.target_index[order]
    steps = np.mod(np.diff(np.concatenate([t, t[:1]])), len(tgt))
    assert steps.sum() == len(tgt)  # one turn: no crossing pairs
    assert len(set(m.source_index.tolist())) == len(m.source_index)
    assert len(set(m.target_index.tolist())) == len(m.target_index)


def test_seed_anchors_win_and_seed_the_rest():
    src, tgt = _outer("figure_stand"), _outer("figure_jump")
    seeds = json.loads((SHAPES / "anchors_figure_stand__figure_jump.json").read_text())["anchors"]
    seeds = np.array(seeds)[:3]
    m = match_outlines(src, tgt, seed_anchors=seeds)
    np.testing.assert_array_equal(m.anchors[:3], seeds)
    assert m.origin[:3] == ("seed",) * 3
    assert len(m.origin) > 3 and "seed" not in m.origin[3:]
    np.testing.assert_array_equal(m.source_index[:3], [4, 43, 10])  # the note's ring indices
    # the seeds' own pairs are not matched again
    auto = m.source_index[3:]
    assert not set(auto.tolist()) & {4, 43, 10}
    # all pairs in one cyclic order
    order = np.argsort(m.source_index)
    t = m.target_index[order]
    assert np.mod(np.diff(np.concatenate([t, t[:1]])), len(tgt)).sum() == len(tgt)


def test_interior_seed_is_kept_but_does_not_cut():
    src, tgt = _outer("dejavu_bold_C"), _outer("dejavu_bold_U")
    auto = match_outlines(src, tgt)
    inner = np.array([[[*src.mean(axis=0)], [*tgt.mean(axis=0)]]])
    m = match_outlines(src, tgt, seed_anchors=inner)
    assert m.origin[0] == "seed" and m.source_index[0] == -1
    assert _pairs(auto) == set(
        zip(m.source_index[1:].tolist(), m.target_index[1:].tolist(), strict=True)
    )


def test_seed_anchors_in_crossing_order_are_refused():
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    seeds = [[sq[0], sq[0]], [sq[1], sq[2]], [sq[2], sq[1]]]
    with pytest.raises(ValueError, match="cyclic order"):
        match_outlines(sq, sq, seed_anchors=seeds)


def test_round_outlines_get_filled_pairs():
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    circle = np.column_stack([np.cos(t), np.sin(t)])
    ellipse = np.column_stack([3 * np.cos(t), np.sin(t)])
    m = match_outlines(circle, ellipse, options=MatchOptions(min_pairs=4))
    assert m.origin == ("fill",) * 4
    assert len(set(m.source_index.tolist())) == 4


def test_reflection_only_when_allowed():
    ring = _outer("dejavu_bold_L")
    mirror = ring * [-1.0, 1.0]
    plain = match_outlines(ring, mirror)
    refl = match_outlines(ring, mirror, options=MatchOptions(allow_reflection=True))
    assert not plain.reflected and refl.reflected
    assert refl.cost < plain.cost
    assert refl.procrustes_rms == pytest.approx(0, abs=1e-9)
    assert all(i == j for i, j in _pairs(refl))


def test_inputs_not_mutated_and_errors():
    src, tgt = _outer("dejavu_bold_C"), _outer("dejavu_bold_S")
    s0, t0 = src.copy(), tgt.copy()
    match_outlines(src, tgt)
    np.testing.assert_array_equal(src, s0)
    np.testing.assert_array_equal(tgt, t0)
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        match_outlines(src[:2], tgt)
    with pytest.raises(ValueError, match="zero area"):
        match_outlines([[0, 0], [1, 0], [2, 0]], tgt)
    with pytest.raises(ValueError, match=r"\(a, 2, 2\)"):
        match_outlines(src, tgt, seed_anchors=[[0, 0]])
