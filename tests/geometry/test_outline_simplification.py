"""conformorph.geometry.outline_simplification: rings to a point budget, features and anchors kept, valid."""

import json
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from conformorph.geometry.outline_features import outline_features
from conformorph.geometry.outline_simplification import SimplifyOptions, simplify_rings

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
NAMES = [
    "flubber_horse",
    "dejavu_bold_B",
    "dejavu_bold_S",
    "figure_stand",
    "annulus_round",
    "bar_bent",
]


def _rings(name: str) -> list[np.ndarray]:
    return [
        np.array(r, dtype=float) for r in json.loads((SHAPES / f"{name}.json").read_text())["rings"]
    ]


def _polygon(rings: list[np.ndarray]) -> Polygon:
    return Polygon(rings[0], rings[1:])


def test_square_with_a_midpoint_by_hand():
    """Five points, one in the middle of a side (zero area): it goes first."""
    ring = np.array([[0, 0], [1, 0], [2, 0], [2, 2], [0, 2]], dtype=float)
    out = simplify_rings([ring], options=SimplifyOptions(budget=4, keep_features=False))
    assert out.index[0].tolist() == [0, 2, 3, 4]
    np.testing.assert_array_equal(out.rings[0], ring[[0, 2, 3, 4]])
    assert out.reached_budget


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("budget", [150, 60])
def test_budget_respected_valid_and_features_kept(name, budget):
    rings = _rings(name)
    out = simplify_rings(rings, options=SimplifyOptions(budget=budget))
    n = sum(len(r) for r in out.rings)
    assert n <= budget or n == sum(len(r) for r in rings) <= budget
    assert out.reached_budget
    poly = _polygon(out.rings)
    assert poly.is_valid
    assert all(Polygon(r).exterior.is_simple for r in out.rings)
    assert poly.area == pytest.approx(_polygon(rings).area, rel=0.05)
    for r, ring in enumerate(rings):  # protected features are still there, same coordinates
        f = outline_features(ring)
        salient = set(f.index[f.saliency >= SimplifyOptions().min_saliency].tolist())
        assert salient <= set(out.index[r].tolist())
        np.testing.assert_array_equal(out.rings[r], ring[out.index[r]])
        assert np.all(np.diff(out.index[r]) > 0)  # input order (and orientation) kept


def test_anchors_kept_exactly_on_vertices_edges_and_inside():
    rings = _rings("flubber_horse")
    doc = json.loads((SHAPES / "anchors_flubber_horse__flubber_star.json").read_text())
    source_anchors = np.array(doc["anchors"])[:, 0]  # 10 on the boundary, 5 inside
    edge_point = 0.5 * (rings[0][100] + rings[0][101])
    keep = np.vstack([source_anchors, edge_point])
    out = simplify_rings(rings, keep_points=keep, options=SimplifyOptions(budget=80))
    assert sum(len(r) for r in out.rings) <= 80
    kept = out.rings[0]
    for p in source_anchors[:10]:
        assert np.min(np.linalg.norm(kept - p, axis=1)) == 0.0
    k = int(np.argmin(np.linalg.norm(kept - edge_point, axis=1)))
    assert np.array_equal(kept[k], edge_point) and out.index[0][k] == -1 and out.protected[0][k]
    poly = _polygon(out.rings)
    assert poly.is_valid
    assert all(poly.contains(Point(p)) for p in source_anchors[10:])


def test_interior_point_blocks_the_removal_that_would_leave_it_outside():
    ring = np.array([[0, 0], [4, 0], [4, 4], [2, 4.5], [0, 4]], dtype=float)
    inner = np.array([[2.0, 4.2]])  # inside only thanks to the vertex (2, 4.5)
    free = simplify_rings([ring], options=SimplifyOptions(budget=4, keep_features=False))
    assert 3 not in free.index[0].tolist()
    kept = simplify_rings(
        [ring], keep_points=inner, options=SimplifyOptions(budget=4, keep_features=False)
    )
    assert 3 in kept.index[0].tolist()
    assert Polygon(kept.rings[0]).contains(Point(inner[0]))


def test_a_hole_never_leaves_its_outer_ring():
    """A hole near a bump of the outer ring: cutting the bump off would cut the hole."""
    outer = np.array([[0, 0], [4, 0], [4, 1], [5, 2], [4, 3], [4, 4], [0, 4]], dtype=float)
    hole = np.array([[4.2, 1.8], [4.2, 2.2], [4.5, 2.0]])  # clockwise
    out = simplify_rings(
        [outer, hole], options=SimplifyOptions(budget=3, keep_features=False, min_ring_points=3)
    )
    assert 3 in out.index[0].tolist()
    assert _polygon(out.rings).is_valid
    assert not out.reached_budget  # 3 points for two rings cannot be met


def test_invariant_to_similarity():
    """Power-of-two scales are exact: the same vertices. A rotation rounds the areas, so
    near-ties (the B's symmetric bowls) may flip: the same counts and nearly the same outline."""
    rings = _rings("dejavu_bold_B")
    base = simplify_rings(rings, options=SimplifyOptions(budget=50))
    for scale in (2.0**-20, 2.0**20):
        out = simplify_rings([scale * r for r in rings], options=SimplifyOptions(budget=50))
        assert [i.tolist() for i in out.index] == [i.tolist() for i in base.index]
    c, s = np.cos(0.3), np.sin(0.3)
    turn = np.array([[c, s], [-s, c]])
    out = simplify_rings([1e6 * r @ turn + 7.0 for r in rings], options=SimplifyOptions(budget=50))
    assert sum(map(len, out.index)) == sum(map(len, base.index))
    back = [(r - 7.0) @ turn.T / 1e6 for r in out.rings]
    diameter = np.ptp(rings[0], axis=0).max()
    assert _polygon(back).hausdorff_distance(_polygon(base.rings)) < 0.01 * diameter


def test_small_input_untouched_inputs_not_mutated_and_errors():
    rings = _rings("dejavu_bold_A")
    before = [r.copy() for r in rings]
    out = simplify_rings(rings, options=SimplifyOptions(budget=200))
    assert [len(r) for r in out.rings] == [len(r) for r in rings]
    for r, b in zip(rings, before, strict=True):
        np.testing.assert_array_equal(r, b)
    with pytest.raises(ValueError, match="protected"):
        simplify_rings(_rings("flubber_horse"), options=SimplifyOptions(budget=10))
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        simplify_rings([[[0, 0], [1, 0]]])
