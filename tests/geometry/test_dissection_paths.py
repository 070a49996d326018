"""Tests of conformorph.geometry.dissection_paths and the gluing stages of conformorph.geometry.patch_dissection."""

import numpy as np
import pytest

from conformorph.geometry.dissection_paths import checked_paths, cut_polygons, dissection_anchors
from conformorph.geometry.patch_dissection import glue_patches, outer_boundary_first
from conformorph.geometry.shape_rings import PathError, ShapeError, validate_rings

SQ = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]])


def test_dissection_anchors_order_and_points():
    S = validate_rings([SQ])
    anchors = np.array(
        [[[4, 4], [4, 4]], [[0, 0], [0, 0]], [[2, 2], [2, 1]], [[4, 0], [4, 0]]], float
    )
    da = dissection_anchors(S, S, anchors)
    assert da.order == [1, 3, 0] and da.on_both.tolist() == [True, True, False, True]
    np.testing.assert_array_equal(da.point(2, 1), [2.0, 1.0])
    np.testing.assert_array_equal(da.point(0, 0), [4.0, 4.0])


def test_checked_paths_and_cut_polygons():
    S = validate_rings([SQ])
    anchors = np.array([[p, p] for p in SQ] + [[[2.0, 2.0], [2.0, 2.0]]])
    da = dissection_anchors(S, S, anchors)
    cuts, used = checked_paths((S, S), da, [[0, 4, 2]])
    assert cuts == [[0, 4, 2]] and used == {4}
    polys = cut_polygons(da.order, cuts)
    assert polys == [[(0, None), (1, None), (2, (2, 4, 0))], [(2, None), (3, None), (0, (0, 4, 2))]]
    # two cuts: three patches, each corner in at least one
    assert len(cut_polygons([0, 1, 2, 3], [[0, 2], [0, 1]])) == 3
    with pytest.raises(PathError, match="cross"):
        checked_paths((S, S), da, [[0, 2], [1, 3]])
    with pytest.raises(PathError, match="twice"):
        checked_paths((S, S), da, [[0, 0]])
    with pytest.raises(PathError, match="boundaries"):
        checked_paths((S, S), da, [[4, 2]])


def test_glue_patches_and_outer_boundary_first():
    # two triangles of a square, each its own patch: the diagonal's ends are duplicated
    Xs = np.array([[0, 0], [1, 0], [1, 1], [0, 0], [1, 1], [0, 1]], dtype=float)
    F = np.array([[0, 1, 2], [3, 4, 5]])
    anchor_vertex = np.array([0, 4])
    Gs, Gt, GF, av = glue_patches(Xs, 2 * Xs, F, anchor_vertex, (np.sqrt(2), 2 * np.sqrt(2)))
    assert Gs.shape == (4, 2) and GF.max() == 3
    np.testing.assert_array_equal(Gs[av], [[0, 0], [1, 1]])
    Bs, Bt, BF, bav, n_loop = outer_boundary_first(Gs, Gt, GF, av)
    assert n_loop == 4 and bav[0] == 0
    np.testing.assert_array_equal(Bt, 2 * Bs)
    with pytest.raises(ShapeError, match="target"):
        moved = 2 * Xs
        moved[3] += 0.5
        glue_patches(Xs, moved, F, anchor_vertex, (np.sqrt(2), 2 * np.sqrt(2)))
