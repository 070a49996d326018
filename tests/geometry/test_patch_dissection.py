"""Dissection into patches along paths between anchors, and the glued compatible triangulation."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.geometry.conformal_relaxation import (
    _reference_inverses,
    symmetric_dirichlet_energy,
)
from conformorph.geometry.flip_repair import _areas
from conformorph.geometry.patch_dissection import (
    dissect_shapes,
    dissected_triangulation,
    straight_side_vertices,
)
from conformorph.geometry.shape_rings import PathError, ShapeError, validate_rings

SQUARE = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
WIDE = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]]
# corners, then the bottom and top midpoints
ANCHORS = np.array(
    [
        [[0.0, 0.0], [0.0, 0.0]],
        [[1.0, 0.0], [2.0, 0.0]],
        [[1.0, 1.0], [2.0, 1.0]],
        [[0.0, 1.0], [0.0, 1.0]],
        [[0.5, 0.0], [0.6, 0.0]],
        [[0.5, 1.0], [1.4, 1.0]],
    ]
)


def _shapes(a=SQUARE, b=WIDE):
    return validate_rings([a]), validate_rings([b])


def _area(ring):
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _boundary_loops(F):
    e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return u[c == 1], c


def test_one_cut_splits_square_and_rectangle_into_the_hand_worked_halves():
    s, t = _shapes()
    patches = dissect_shapes(s, t, ANCHORS, [[4, 5]])
    assert len(patches) == 2
    # the cut x = 0.5 (source) / from (0.6, 0) to (1.4, 1) (target) halves the square,
    # and splits the 2 × 1 rectangle into trapezoids of areas 1.0 and 1.0
    src = sorted(_area(p.source_ring) for p in patches)
    tgt = sorted(_area(p.target_ring) for p in patches)
    np.testing.assert_allclose(src, [0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(tgt, [1.0, 1.0], atol=1e-12)
    for p in patches:
        assert _area(p.source_ring) > 0 and _area(p.target_ring) > 0  # counter-clockwise
        assert {4, 5} <= set(p.anchor_index.tolist())
    # both patches carry the same cut points, in both shapes
    on_cut = [np.sort(p.source_ring[np.isclose(p.source_ring[:, 0], 0.5)][:, 1]) for p in patches]
    np.testing.assert_array_equal(on_cut[0], on_cut[1])
    assert on_cut[0].size >= 3


def test_glued_mesh_is_one_compatible_disk_with_the_cut_inside():
    s, t = _shapes()
    ct = dissected_triangulation(s, t, ANCHORS, [[4, 5]], triangles_per_shape=60, relax=False)
    assert ct.flipped == (0, 0)
    # total areas are the shapes' areas, every triangle positive in both
    assert np.isclose(_areas(ct.source_V, ct.F).sum(), 1.0)
    assert np.isclose(_areas(ct.target_V, ct.F).sum(), 2.0)
    assert np.all(_areas(ct.source_V, ct.F) > 0) and np.all(_areas(ct.target_V, ct.F) > 0)
    edges, counts = _boundary_loops(ct.F)
    assert counts.max() == 2  # manifold
    n = ct.source_V.shape[0]
    assert n - (edges.shape[0] + (counts == 2).sum()) + ct.F.shape[0] == 1  # Euler: a disk
    # the outer boundary comes first, in order, and no cut vertex is on it
    assert edges.shape[0] == ct.boundary_vertices
    assert set(np.unique(edges)) == set(range(ct.boundary_vertices))
    cut = np.flatnonzero(
        np.isclose(ct.source_V[:, 0], 0.5)
        & (ct.source_V[:, 1] > 1e-9)
        & (ct.source_V[:, 1] < 1 - 1e-9)
    )
    assert cut.size >= 2 and np.all(cut >= ct.boundary_vertices)
    # the cut's vertices lie on the target's cut
    tc = ct.target_V[cut]
    np.testing.assert_allclose(tc[:, 0], 0.6 + 0.8 * tc[:, 1], atol=1e-9)
    for i, v in enumerate(ct.anchor_vertices):
        np.testing.assert_allclose(ct.source_V[v], ANCHORS[i, 0], atol=1e-12)
        np.testing.assert_allclose(ct.target_V[v], ANCHORS[i, 1], atol=1e-12)


def test_relaxation_lowers_the_maps_distortion_and_keeps_boundary_and_anchors():
    s, t = _shapes()
    raw = dissected_triangulation(s, t, ANCHORS, [[4, 5]], triangles_per_shape=60, relax=False)
    ct = dissected_triangulation(s, t, ANCHORS, [[4, 5]], triangles_per_shape=60)
    np.testing.assert_array_equal(ct.F, raw.F)
    np.testing.assert_array_equal(ct.source_V, raw.source_V)
    b = ct.boundary_vertices
    for corner in WIDE:  # the target's corners stay (its other boundary points slide)
        assert np.any(np.all(ct.target_V[:b] == corner, axis=1))
    np.testing.assert_array_equal(ct.target_V[ct.anchor_vertices], raw.target_V[ct.anchor_vertices])
    assert ct.flipped == (0, 0)

    def sd(T):
        Pinv, area = _reference_inverses(ct.source_V * np.sqrt(2.0), ct.F)
        return symmetric_dirichlet_energy(T, ct.F, Pinv, area)

    # lower, and above the bound 4 per unit area that only a rotation reaches (the
    # target is twice as wide: no map onto it is a rotation everywhere)
    assert 4.0 < sd(ct.target_V) / 2.0 < sd(raw.target_V) / 2.0


def test_a_path_through_an_interior_anchor_bends_there_in_both_shapes():
    s, t = _shapes()
    anchors = np.vstack([ANCHORS, [[[0.3, 0.5], [1.5, 0.5]]]])
    patches = dissect_shapes(s, t, anchors, [[4, 6, 5]])
    assert len(patches) == 2
    for p in patches:
        assert 6 in p.anchor_index.tolist()
    # source: the bent cut leaves 0.5 − 0.1 = 0.4 on the left; target: 0.6·… by the shoelace rule
    left = min(patches, key=lambda p: _area(p.source_ring))
    assert np.isclose(_area(left.source_ring), 0.4)
    ct = dissected_triangulation(s, t, anchors, [[4, 6, 5]], triangles_per_shape=60)
    assert ct.flipped == (0, 0)
    v = ct.anchor_vertices[6]
    np.testing.assert_allclose(ct.source_V[v], [0.3, 0.5])
    np.testing.assert_allclose(ct.target_V[v], [1.5, 0.5])
    assert v >= ct.boundary_vertices


def test_finer_patches_stay_compatible_and_grow():
    s, t = _shapes()
    counts = []
    for tps in (30, 120, 480):
        ct = dissected_triangulation(s, t, ANCHORS, [[4, 5]], triangles_per_shape=tps)
        assert ct.flipped == (0, 0)
        counts.append(ct.n_triangles)
    assert counts[0] < counts[1] < counts[2]


L_SHAPE = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]]


@pytest.mark.parametrize(
    "anchors, paths, message",
    [
        (ANCHORS, [[4, 9]], "names anchor 9"),
        (ANCHORS, [[4]], "at least two"),
        (ANCHORS, [[4, 4]], "twice"),
        (np.vstack([ANCHORS, [[[0.3, 0.5], [1.5, 0.5]]]]), [[4, 6]], "must start and end"),
        (np.vstack([ANCHORS, [[[0.3, 0.5], [1.5, 0.5]]]]), [[4, 6, 5], [0, 6, 2]], "another path"),
        (ANCHORS, [[4, 5], [0, 2]], "cross"),
        (ANCHORS, [[4, 5], [5, 4]], "same cut"),
    ],
)
def test_bad_paths_are_named(anchors, paths, message):
    s, t = _shapes()
    with pytest.raises(PathError, match=message) as info:
        dissect_shapes(s, t, anchors, paths)
    assert info.value.index == len(paths) - 1


def test_a_path_leaving_a_shape_says_which_and_where():
    # across the L's notch: from (2, 1) to (1, 2) is outside the L, inside the square
    s, t = validate_rings([L_SHAPE]), validate_rings([[[0, 0], [2, 0], [2, 2], [0, 2]]])
    anchors = np.array(
        [[[0, 0], [0, 0]], [[2, 0], [2, 0]], [[2, 1], [2, 1]], [[1, 2], [1, 2]], [[0, 2], [0, 2]]],
        dtype=float,
    )
    with pytest.raises(PathError, match="leaves the source shape between anchors 2 and 3"):
        dissect_shapes(s, t, anchors, [[2, 3]])


def test_shapes_with_holes_are_not_dissected():
    hole = [[0.4, 0.4], [0.4, 0.6], [0.6, 0.6], [0.6, 0.4]]
    s = validate_rings([SQUARE, hole])
    t = validate_rings([WIDE, [[0.9, 0.4], [0.9, 0.6], [1.1, 0.6], [1.1, 0.4]]])
    with pytest.raises(ShapeError, match="holes"):
        dissect_shapes(s, t, ANCHORS, [[4, 5]])


def test_straight_side_vertices_are_those_between_collinear_neighbours():
    ring = np.array([[0.0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [1.5, 1.5], [0, 1]])
    i, d = straight_side_vertices(ring)
    assert i.tolist() == [1, 2]  # corners 0, 3, 4, 6 and the bent top 5 are not
    np.testing.assert_allclose(d, [[1.0, 0.0], [1.0, 0.0]])
    i, _ = straight_side_vertices(ring, exclude=np.array([2, 40]))  # out of range: ignored
    assert i.tolist() == [1]
    # a vertex that doubles back on the line is no side vertex
    assert straight_side_vertices(np.array([[0.0, 0], [2, 0], [1, 0], [1, 1]]))[0].size == 0
    with pytest.raises(ValueError, match="ring must"):
        straight_side_vertices(np.zeros((2, 2)))


def test_relaxation_slides_target_boundary_points_along_the_sides():
    # the cut's bottom end is anchored; the boundary points between anchors slide along
    # the target's straight sides, and stay on them
    s, t = _shapes()
    raw = dissected_triangulation(s, t, ANCHORS, [[4, 5]], triangles_per_shape=60, relax=False)
    ct = dissected_triangulation(s, t, ANCHORS, [[4, 5]], triangles_per_shape=60)
    b = ct.boundary_vertices
    moved = np.flatnonzero(np.any(ct.target_V[:b] != raw.target_V[:b], axis=1))
    assert moved.size > 0
    on_side = np.isclose(ct.target_V[moved], 0.0) | np.isclose(ct.target_V[moved], [2.0, 1.0])
    assert np.all(on_side.any(axis=1))  # still on x = 0, x = 2, y = 0 or y = 1
    np.testing.assert_array_equal(ct.target_V[ct.anchor_vertices], raw.target_V[ct.anchor_vertices])
    assert ct.flipped == (0, 0)


def test_the_committed_horse_star_paths_cut_both_shapes_into_five_matching_patches():
    # the fixture behind `conformorph morph2d horse star` reaching the star (SOURCES.md)
    import json
    from pathlib import Path

    folder = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
    s, t = (
        validate_rings(json.loads((folder / f"flubber_{n}.json").read_text())["rings"])
        for n in ("horse", "star")
    )
    data = json.loads((folder / "anchors_flubber_horse__flubber_star.json").read_text())
    patches = dissect_shapes(s, t, np.array(data["anchors"]), data["paths"])
    assert len(patches) == 5
    assert sum(_area(p.source_ring) for p in patches) == pytest.approx(s.area, rel=1e-9)
    assert sum(_area(p.target_ring) for p in patches) == pytest.approx(t.area, rel=1e-9)
    assert all(_area(p.source_ring) > 0 and _area(p.target_ring) > 0 for p in patches)
