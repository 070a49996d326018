"""Composite maps that fold a few triangles are repaired locally, not refused (issue 27)."""

import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.mesh_errors import FoldedMapError
from conformorph.geometry.point_location import PointLocator
from conformorph.pipelines.face_morph.resampling import (
    composite_fold_check,
    repair_composite_folds,
)


def _case():
    uv, F = refine_disk_mesh(*landmark_disk_mesh(np.array([[0.0, 0.0]]), n_boundary=12), 3)
    rim = np.flatnonzero(np.isclose(np.linalg.norm(uv, axis=1), 1.0))
    r = np.linalg.norm(uv, axis=1)
    a = 0.5 * (1 - r**2)
    smooth = np.c_[
        np.cos(a) * uv[:, 0] - np.sin(a) * uv[:, 1], np.sin(a) * uv[:, 0] + np.cos(a) * uv[:, 1]
    ]
    folded = smooth.copy()
    v = int(np.flatnonzero((r > 0.4) & (r < 0.9))[3])
    ring = np.setdiff1d(np.unique(F[(F == v).any(axis=1)]), [v])
    folded[v] += 1.6 * (smooth[ring[0]] - smooth[v])
    key = {"F": F, "Vn": np.c_[uv, 0.2 * (1 - r**2)]}  # key 1: the disk's own mesh, lifted
    return uv, F, rim, folded, [key, key], [PointLocator(uv, F)] * 2, v


def test_a_composite_map_folding_one_triangle_is_repaired_and_reported():
    uv, F, rim, folded, prepared, locators, v = _case()
    with pytest.raises(FoldedMapError, match="refusing"):
        composite_fold_check(uv, [uv, folded], F, refuse="dmt")
    comp, repairs = repair_composite_folds(uv, F, rim, [uv, folded], locators, prepared)
    folds, min_jac = composite_fold_check(uv, comp, F, refuse="dmt")  # no longer refused
    assert folds == [0] and min_jac[0] > 0
    (rep,) = repairs
    assert rep["key"] == 1 and rep["repaired"] and rep["folded_triangles"] >= 1
    assert 1 <= rep["moved_nodes"] < 0.1 * len(uv)
    assert rep["max_disk_displacement"] > 0 and 0 < rep["max_surface_displacement"] < 1
    np.testing.assert_array_equal(comp[1][rim], folded[rim])  # the boundary stays put
    assert comp[0] is not None and np.array_equal(comp[0], uv)


def test_maps_that_do_not_fold_are_untouched_and_not_reported():
    uv, F, rim, folded, prepared, locators, _ = _case()
    comp, repairs = repair_composite_folds(uv, F, rim, [uv, uv.copy()], locators, prepared)
    assert repairs == [] and np.array_equal(comp[1], uv)
