"""conformorph.geometry.hole_pairing: holes of two shapes paired by position and size."""

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.geometry.hole_pairing import HolePairingOptions, pair_holes, ring_centroid_area

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
OUTER = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], dtype=float)


def _square(x: float, y: float, h: float) -> np.ndarray:
    return np.array([[x - h, y - h], [x - h, y + h], [x + h, y + h], [x + h, y - h]])  # CW


def test_centroid_and_area_by_hand():
    c, a = ring_centroid_area([[0, 0], [4, 0], [0, 3]])
    assert c == pytest.approx(complex(4 / 3, 1))
    assert a == pytest.approx(6.0)
    c, a = ring_centroid_area(_square(1e8 + 1, -1e8, 1e-3))  # far from the origin, clockwise
    assert a == pytest.approx(-4e-6, rel=1e-4)  # the corners themselves round at 1.5e-8
    assert c.real == pytest.approx(1e8 + 1, abs=1e-9)


def test_pairs_by_position_not_by_list_order():
    src = [_square(3, 3, 1), _square(7, 7, 1), _square(3, 7, 0.5)]
    tgt = [_square(7.2, 6.8, 1.1), _square(3, 7.1, 0.5), _square(2.9, 3, 0.9)]
    hp = pair_holes(src, tgt, source_outer=OUTER, target_outer=OUTER)
    assert hp.pairs.tolist() == [[0, 2], [1, 0], [2, 1]]
    assert hp.unpaired_source.size == 0 and hp.unpaired_target.size == 0
    assert np.all(hp.cost < 0.2)


def test_size_decides_between_equally_near_holes():
    src = [_square(5, 5, 2.0), _square(5, 5, 0.5)]  # nested positions, different sizes
    tgt = [_square(5, 5.1, 0.5), _square(5, 4.9, 2.0)]
    hp = pair_holes(src, tgt, source_outer=OUTER, target_outer=OUTER)
    assert hp.pairs.tolist() == [[0, 1], [1, 0]]


def test_normal_frame_and_rotation():
    """Scaling and moving the target shape changes nothing; rotating it needs ``rotation``."""
    src = [_square(3, 3, 1), _square(7, 7, 1.5)]
    moved = [h * 1e6 + [5e6, -2e6] for h in src]
    outer = OUTER * 1e6 + [5e6, -2e6]
    hp = pair_holes(src, moved, source_outer=OUTER, target_outer=outer)
    assert hp.pairs.tolist() == [[0, 0], [1, 1]] and np.all(hp.cost < 1e-9)
    turn = np.array([[-1.0, 0], [0, -1]])  # half turn about the square's centre
    turned = [(h - 5) @ turn.T + 5 for h in src]
    # without the rotation, hole 0 is where hole 1 went: sizes alone disagree
    assert pair_holes(src, turned, source_outer=OUTER, target_outer=OUTER).pairs.tolist() != [
        [0, 0],
        [1, 1],
    ]
    hp = pair_holes(src, turned, source_outer=OUTER, target_outer=OUTER, rotation=np.pi)
    assert hp.pairs.tolist() == [[0, 0], [1, 1]] and np.all(hp.cost < 1e-9)


def test_unpaired_when_counts_differ_or_too_far():
    src = [_square(3, 3, 1), _square(7, 7, 1)]
    hp = pair_holes(src, [_square(7, 7, 1)], source_outer=OUTER, target_outer=OUTER)
    assert hp.pairs.tolist() == [[1, 0]] and hp.unpaired_source.tolist() == [0]
    far = pair_holes(
        [_square(2, 2, 1)],
        [_square(8, 8, 1)],
        source_outer=OUTER,
        target_outer=OUTER,
        options=HolePairingOptions(max_cost=0.3),
    )
    assert far.pairs.shape == (0, 2) and far.unpaired_target.tolist() == [0]
    none = pair_holes([], [], source_outer=OUTER, target_outer=OUTER)
    assert none.pairs.shape == (0, 2)


def test_fixture_annulus_pair():
    rs = json.loads((SHAPES / "annulus_round.json").read_text())["rings"]
    rt = json.loads((SHAPES / "annulus_square.json").read_text())["rings"]
    hp = pair_holes(rs[1:], rt[1:], source_outer=rs[0], target_outer=rt[0])
    assert hp.pairs.tolist() == [[0, 0]]


def test_errors():
    with pytest.raises(ValueError, match="zero area"):
        ring_centroid_area([[0, 0], [1, 1], [2, 2]])
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        pair_holes([[[0, 0], [1, 0]]], [], source_outer=OUTER, target_outer=OUTER)
