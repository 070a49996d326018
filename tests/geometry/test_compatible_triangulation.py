"""Tests of conformorph.geometry.compatible_triangulation."""

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.geometry.compatible_mesh_quality import _collapse_slivers
from conformorph.geometry.compatible_triangulation import (
    compatible_triangulation,
    overlay_triangle_count,
)
from conformorph.geometry.consistent_boundaries import _consistent_arc
from conformorph.geometry.green_lagrange_strain import signed_areas
from conformorph.geometry.mean_value_patches import _disk_mesh
from conformorph.geometry.parameter_overlay import _edges_meeting_triangle
from conformorph.geometry.shape_rings import (
    AnchorOutsideShapeError,
    HoleCorrespondenceError,
    ShapeError,
    ShapeRings,
    TooFewAnchorsError,
    distance_to_rings,
    validate_rings,
)

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
SQUARE = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])


def load_pair(a: str, b: str):
    S = validate_rings(json.loads((SHAPES / f"{a}.json").read_text())["rings"])
    T = validate_rings(json.loads((SHAPES / f"{b}.json").read_text())["rings"])
    anchors = np.array(json.loads((SHAPES / f"anchors_{a}__{b}.json").read_text())["anchors"])
    return S, T, anchors


def check(ct, S, T, anchors):
    assert ct.flipped == (0, 0)
    assert np.all(signed_areas(ct.source_V, ct.F) > 0) and np.all(
        signed_areas(ct.target_V, ct.F) > 0
    )
    assert signed_areas(ct.source_V, ct.F).sum() == pytest.approx(S.area, rel=1e-9)
    assert signed_areas(ct.target_V, ct.F).sum() == pytest.approx(T.area, rel=1e-9)
    nb = ct.boundary_vertices
    for shape, X in ((S, ct.source_V), (T, ct.target_V)):
        diag = np.linalg.norm(np.ptp(shape.outer, axis=0))
        assert distance_to_rings(shape, X[:nb]).max() <= 1e-9 * diag
        # every corner of the original ring is kept as a vertex
        d = np.linalg.norm(shape.outer[:, None] - X[None, :nb], axis=2).min(axis=1)
        assert d.max() <= 1e-9 * diag
    assert np.allclose(ct.source_V[ct.anchor_vertices], anchors[:, 0])
    assert np.allclose(ct.target_V[ct.anchor_vertices], anchors[:, 1])


def test_hand_worked_square_to_rectangle():
    S = validate_rings([SQUARE])
    T = validate_rings([SQUARE * [2.0, 1.0]])
    anchors = np.stack([SQUARE, SQUARE * [2.0, 1.0]], axis=1)
    ct = compatible_triangulation(S, T, anchors, triangles_per_shape=20, smoothing_rounds=1)
    check(ct, S, T, anchors)
    # corresponding boundary points are at equal arc-length fractions between the
    # corner anchors, so on the boundary the correspondence is x ↦ (2x, y) exactly
    nb = ct.boundary_vertices
    assert np.allclose(ct.target_V[:nb], ct.source_V[:nb] * [2.0, 1.0], atol=1e-12)


def test_boundary_anchor_near_a_corner_keeps_its_place():
    # an anchor a tenth of the way along a side is not moved onto the corner
    # (a quarter-side snap did, so its vertex sat 0.1 from the anchor)
    S = validate_rings([SQUARE])
    T = validate_rings([SQUARE * [2.0, 1.0]])
    anchors = np.stack([SQUARE, SQUARE * [2.0, 1.0]], axis=1)
    anchors = np.concatenate([anchors, [[[0.1, 0.0], [0.6, 0.0]]]])
    ct = compatible_triangulation(S, T, anchors, triangles_per_shape=20, smoothing_rounds=1)
    check(ct, S, T, anchors)
    # a point within the on-boundary tolerance of a corner still snaps onto it
    near = np.concatenate([anchors[:4], [[[1e-5, 1.0], [2e-5, 1.0]]]])
    with pytest.raises(ShapeError):
        compatible_triangulation(S, T, near, triangles_per_shape=20, smoothing_rounds=1)


def test_letters_I_to_L_different_vertex_counts():
    S, T, anchors = load_pair("dejavu_bold_I", "dejavu_bold_L")
    assert S.outer.shape[0] != T.outer.shape[0]
    ct = compatible_triangulation(S, T, anchors, smoothing_rounds=1)
    check(ct, S, T, anchors)
    assert min(ct.min_angle) > 1.0
    assert ct.n_triangles < 2000


@pytest.mark.parametrize("s", [1e-3, 1e3])
def test_similarity_of_one_shape_still_gives_valid_meshes(s):
    # Triangle's Steiner points depend on the coordinates, so the meshes are not
    # equal up to the similarity; the guarantees (no flips, corners, anchors) hold.
    S, T, anchors = load_pair("dejavu_bold_I", "dejavu_bold_L")
    th = 0.5
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    S2 = validate_rings([s * S.outer @ R.T])
    a2 = np.stack([s * anchors[:, 0] @ R.T, anchors[:, 1]], 1)
    ct = compatible_triangulation(S2, T, a2, smoothing_rounds=1)
    check(ct, S2, T, a2)


def test_errors():
    S = validate_rings([SQUARE])
    H = validate_rings([SQUARE * 4, (SQUARE + 1)[::-1]])
    anchors = np.stack([SQUARE, SQUARE], axis=1)
    with pytest.raises(HoleCorrespondenceError, match="0 hole.*1"):
        compatible_triangulation(S, H, anchors)
    with pytest.raises(AnchorOutsideShapeError):
        compatible_triangulation(S, S, anchors + [[0, 0], [5, 5]])
    with pytest.raises(TooFewAnchorsError):
        compatible_triangulation(
            S, S, np.array([[[0.5, 0.5], [0.5, 0.5]], [[0.4, 0.4], [0.4, 0.4]]])
        )
    with pytest.raises(ShapeError, match="orders"):
        compatible_triangulation(S, S, np.stack([SQUARE, SQUARE[[0, 2, 1, 3]]], axis=1))


def test_inputs_not_mutated():
    S, T, anchors = load_pair("dejavu_bold_I", "dejavu_bold_L")
    c = S.outer.copy(), T.outer.copy(), anchors.copy()
    compatible_triangulation(S, T, anchors, smoothing_rounds=0)
    assert (
        np.array_equal(S.outer, c[0])
        and np.array_equal(T.outer, c[1])
        and np.array_equal(anchors, c[2])
    )


# ---- every target pair: zero flipped triangles in both meshes, far fewer than the overlay
PAIRS = [
    ("dejavu_bold_I", "dejavu_bold_L", 200, 1),
    ("dejavu_bold_L", "dejavu_bold_T", 200, 1),
    ("dejavu_bold_C", "dejavu_bold_S", 200, 0),
    ("dejavu_bold_S", "dejavu_bold_U", 60, 0),
    ("figure_stand", "figure_jump", 60, 0),
    ("flubber_horse", "flubber_heart", 60, 0),  # simplify=False below, to stay fast
]


@pytest.mark.parametrize("a, b, tps, smooth", PAIRS)
def test_target_pairs_have_no_flips(a, b, tps, smooth):
    S, T, anchors = load_pair(a, b)
    ct = compatible_triangulation(
        S,
        T,
        anchors,
        triangles_per_shape=tps,
        smoothing_rounds=smooth,
        simplify=a != "flubber_horse",
    )
    check(ct, S, T, anchors)
    assert 0 < ct.n_triangles < ct.overlay_triangles
    if a != "flubber_horse":  # the horse keeps slivers (min angle < 0.01°), see the benchmark
        assert min(ct.min_angle) > 0.0


def test_one_hole_each_annulus_pair():
    S, T, anchors = load_pair("annulus_round", "annulus_square")
    ct = compatible_triangulation(S, T, anchors, smoothing_rounds=1)
    check(ct, S, T, anchors)
    nb, nh = ct.boundary_vertices, ct.hole_vertices
    assert nh >= max(S.holes[0].shape[0], T.holes[0].shape[0])
    for shape, X in ((S, ct.source_V), (T, ct.target_V)):
        hole = ShapeRings(shape.holes[0][::-1].copy(), (), ())
        assert distance_to_rings(hole, X[nb : nb + nh]).max() <= 1e-9
        # every hole corner is kept
        d = np.linalg.norm(shape.holes[0][:, None] - X[None, nb : nb + nh], axis=2).min(axis=1)
        assert d.max() <= 1e-9
    # one boundary loop for the outer ring and one for the hole (the cut is glued shut)
    from conformorph.geometry.boundary_loop import boundary_loops

    loops = boundary_loops(ct.F)
    assert sorted(len(lp) for lp in loops) == sorted([nb, nh])


def test_different_hole_counts_are_refused_by_name():
    S, T, anchors = load_pair("dejavu_bold_A", "dejavu_bold_B")
    assert (len(S.holes), len(T.holes)) == (1, 2)
    with pytest.raises(HoleCorrespondenceError, match="1 hole.*2"):
        compatible_triangulation(S, T, anchors)


# ---- hand-worked cases of the building blocks
def test_overlay_count_two_diagonals_of_a_square():
    sq = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])
    Fa = np.array([[0, 1, 2], [0, 2, 3]])
    Fb = np.array([[0, 1, 3], [1, 2, 3]])
    # the diagonals cross once: 5 vertices, 4 triangles
    assert overlay_triangle_count(sq, Fa, sq, Fb, 4) == 4
    # identical triangulations overlay to themselves
    assert overlay_triangle_count(sq, Fa, sq, Fa, 4) == 2


def test_edges_meeting_triangle():
    uv = np.array([[0.0, 0], [3, 0], [0, 3], [1, 1], [5, 5], [6, 5]])
    E = np.array([[0, 3], [4, 5], [1, 2], [0, 4]])
    tri = np.array([[0.5, 0.5], [2.0, 0.5], [0.5, 2.0]])
    # [0,3] ends inside; [4,5] far away; [1,2] passes outside (x + y = 3 > 2.5);
    # [0,4] crosses the triangle through its inside
    assert _edges_meeting_triangle(tri, uv, E).tolist() == [True, False, False, True]
    assert _edges_meeting_triangle(tri[::-1], uv, E).tolist() == [True, False, False, True]


def test_consistent_arc_hand_worked():
    # source: straight segment with a vertex at 1/4; target: straight with a vertex at 3/4
    ps = np.array([[0.0, 0], [1, 0], [4, 0]])
    pt = np.array([[0.0, 0], [0, 3], [0, 4]])
    Xs, Xt = _consistent_arc(ps, pt, 10.0, 10.0)
    np.testing.assert_allclose(Xs, [[0, 0], [1, 0], [3, 0]])
    np.testing.assert_allclose(Xt, [[0, 0], [0, 1], [0, 3]])
    # subdivision: equally many pieces in both, none longer than h
    Xs, Xt = _consistent_arc(ps[[0, 2]], pt[[0, 2]], 1.0, 3.0)
    assert Xs.shape == Xt.shape == (4, 2)
    np.testing.assert_allclose(Xs[:, 0], [0, 1, 2, 3])


def test_disk_mesh_cuts_a_square_annulus_open():
    # a square with a square hole, cut along y = 0 from (2, 0) to (1, 0)
    from conformorph.geometry.triangulate_shape import triangulate_segments

    outer = np.array([[2.0, 0], [2, 2], [-2, 2], [-2, -2], [2, -2]])
    hole = np.array([[1.0, 0], [1, -1], [-1, -1], [-1, 1], [1, 1]])  # clockwise
    U = np.vstack([outer, hole])
    # disk ring: outer from P=(2,0) round to P again, along the cut to Q=(1,0), round the hole, back
    uid = np.array([0, 1, 2, 3, 4, 0, 5, 6, 7, 8, 9, 5])
    ring_edges = np.unique(np.sort(np.c_[uid, np.roll(uid, -1)], axis=1), axis=0)
    V, F = triangulate_segments(
        U, ring_edges, hole_points=np.array([[0.0, 0.0]]), split_inner_segments=False
    )
    copies = {0: [0, 5], 5: [6, 11]}
    X, Fd = _disk_mesh(uid, copies, {(0, 5)}, V, F, 10)
    E = {(int(f[k]), int(f[(k + 1) % 3])) for f in Fd for k in range(3)}
    boundary = {e for e in E if (e[1], e[0]) not in E}
    assert boundary == {(i, (i + 1) % 12) for i in range(12)}
    assert np.all(signed_areas(X, Fd) > 0)


def test_collapse_slivers_hand_worked():
    # a unit square fanned around a free vertex just above the bottom edge: the
    # sliver (0, 1, v) goes when v merges into a corner, leaving two 45° triangles
    V = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.01]])
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    fixed = np.array([True, True, True, True, False])
    F2, k = _collapse_slivers(V, V * [2.0, 1.0], F, fixed, passes=2)
    assert k == 1 and F2.shape == (2, 3)
    assert not np.any(F2 == 4)
    assert signed_areas(V, F2).sum() == pytest.approx(1.0)
    assert np.all(signed_areas(V, F2) > 0)
    # a fixed vertex is never moved
    F3, k3 = _collapse_slivers(V, V, F, np.ones(5, dtype=bool), passes=2)
    assert k3 == 0 and np.array_equal(F3, F)


def test_explicit_hole_match_is_checked():
    S, T, anchors = load_pair("annulus_round", "annulus_square")
    ct = compatible_triangulation(S, T, anchors, hole_match=[0])
    assert ct.flipped == (0, 0)
    with pytest.raises(ValueError, match="permutation"):
        compatible_triangulation(S, T, anchors, hole_match=[1])
