"""Tests of conformorph.geometry.mean_value_patches, conformorph.geometry.merged_triangulation and conformorph.geometry.flip_repair
(the disk patches' maps, the merged triangulation, the flip repair)."""

import numpy as np

from conformorph.geometry.boundary_anchors import boundary_anchors
from conformorph.geometry.consistent_boundaries import consistent_boundaries
from conformorph.geometry.flip_repair import _areas, repair_flips
from conformorph.geometry.hole_cuts import hole_cuts
from conformorph.geometry.mean_value_patches import glue_cut, patch_maps
from conformorph.geometry.merged_triangulation import MergedPoints, refined_merged_triangulation
from conformorph.geometry.shape_rings import validate_rings

SQ8 = np.array([[0, 0], [2, 0], [4, 0], [4, 2], [4, 4], [2, 4], [0, 4], [0, 2]], dtype=float)
HOLE = np.array([[1.0, 1.0], [1.0, 2.0], [2.0, 2.0], [2.0, 1.0]])
CORNERS = SQ8[::2]


def _stages(rings_t, inner=()):
    S, T = validate_rings([SQ8, HOLE]), validate_rings(rings_t)
    anchors = np.array(
        [[p, q] for p, q in zip(CORNERS, validate_rings(rings_t).outer[::2], strict=True)]
        + list(inner)
    )
    ba = boundary_anchors(S, T, anchors)
    cuts = hole_cuts(S, T, ba.s_par, ba.t_par)
    b = consistent_boundaries(S, T, cuts, (1.0, 1.0))
    maps = patch_maps(S, T, b, cuts.hole_match, anchors[ba.inner], (50, 25.0))
    return S, T, anchors[ba.inner], b, maps


def test_patch_maps_put_the_boundary_on_the_circle_and_are_unfolded():
    _, _, inner, b, maps = _stages([2.0 * SQ8, 2.0 * HOLE + [0.5, 0.0]])
    np.testing.assert_allclose(np.linalg.norm(maps.circle, axis=1), 1.0)
    for (_X, F), uv in zip(maps.meshes, maps.uvs, strict=True):
        np.testing.assert_array_equal(uv[: b.nb], maps.circle)
        assert np.all(_areas(uv, F) > 0)  # Floater: a bijection onto the polygon
        assert np.all(np.linalg.norm(uv[b.nb :], axis=1) < 1.0)
    assert maps.overlay_triangles >= max(F.shape[0] for _, F in maps.meshes)


def test_merged_triangulation_unflipped_and_glued():
    _, _, inner, b, maps = _stages([2.0 * SQ8, 2.0 * HOLE + [0.5, 0.0]])
    pts = MergedPoints(maps, 0)
    n0 = len(pts.points)
    assert pts.initial == n0 and pts.index(0, 3) == 3  # boundary entries keep their index
    UV, F, Xd, rounds = refined_merged_triangulation(maps, pts, inner, 60)
    assert all(np.all(_areas(X, F) > 0) for X in Xd)
    Xs, Xt, F2, fixed = glue_cut(b, F, Xd, 0)
    assert Xs.shape[0] == Xt.shape[0] < UV.shape[0] - b.nb + b.n_u + 1
    assert fixed[: b.n_outer + b.n_hole].all() and not fixed[b.n_u :].any()
    # glued: every vertex is used, the triangles keep their orientation
    assert np.unique(F2).size == Xs.shape[0]
    assert np.all(_areas(Xs, F2) > 0) and np.all(_areas(Xt, F2) > 0)


def test_merged_points_index_adds_a_vertex_once():
    _, _, _, b, maps = _stages([2.0 * SQ8, 2.0 * HOLE])
    pts = MergedPoints(maps, 0)
    v = maps.uvs[1].shape[0] - 1
    before, known = len(pts.points), (1, v) in pts.reg
    i = pts.index(1, v)
    assert len(pts.points) == before + (not known)
    assert pts.index(1, v) == i and len(pts.points) == before + (not known)
    np.testing.assert_array_equal(pts.points[i - b.nb], maps.uvs[1][v])


def test_repair_flips_fixes_a_flipped_vertex_and_leaves_good_meshes_alone():
    V = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [1.0, 1.0]])
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    fixed = np.array([True, True, True, True, False])
    Xs, Xt, F1, rounds = repair_flips(V.copy(), V.copy(), F, fixed, 4)
    assert rounds == 0 and np.array_equal(F1, F) and np.array_equal(Xs, V)
    bad = V.copy()
    bad[4] = [3.0, 1.0]  # outside: two triangles flip
    Xs, Xt, F1, rounds = repair_flips(V.copy(), bad, F, fixed, 4)
    assert rounds >= 1 and np.all(_areas(Xt, F1) > 0) and np.all(_areas(Xs, F1) > 0)
    np.testing.assert_array_equal(Xt[:4], V[:4])  # fixed vertices stay
