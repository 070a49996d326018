import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.map_fold_repair import map_fold_repair
from conformorph.geometry.map_jacobian import fold_report


def _disk(levels=3):
    uv, F = refine_disk_mesh(*landmark_disk_mesh(np.array([[0.0, 0.0]]), n_boundary=12), levels)
    rim = np.isclose(np.linalg.norm(uv, axis=1), 1.0)
    return uv, F, rim


def _smooth_map(uv):
    """A smooth bijection of the disk onto itself (a radial twist, boundary fixed)."""
    r = np.linalg.norm(uv, axis=1)
    a = 0.6 * (1 - r**2)
    c, s = np.cos(a), np.sin(a)
    return np.c_[c * uv[:, 0] - s * uv[:, 1], s * uv[:, 0] + c * uv[:, 1]]


def _folded(uv, F, rim):
    """The smooth map with one interior vertex pushed across its one-ring."""
    Y = _smooth_map(uv)
    inner = np.flatnonzero(~rim & (np.linalg.norm(uv, axis=1) > 0.4))
    v = int(inner[0])
    ring = np.setdiff1d(np.unique(F[(F == v).any(axis=1)]), [v])
    Y[v] = Y[v] + 1.6 * (Y[ring[0]] - Y[v])
    return Y, v


def test_one_pushed_vertex_is_unfolded_locally():
    uv, F, rim = _disk()
    Y, v = _folded(uv, F, rim)
    assert fold_report(uv, Y, F).n_folded > 0
    r = map_fold_repair(uv, Y, F, fixed=rim)
    assert r.repaired and fold_report(uv, r.target_uv, F).n_folded == 0
    assert v in r.moved and r.rings >= 1
    # everything outside the re-solved region is where the map put it
    still = np.setdiff1d(np.arange(len(uv)), r.moved)
    assert np.array_equal(r.target_uv[still], Y[still])
    assert r.moved.size < 0.1 * len(uv)
    assert r.max_displacement == pytest.approx(np.linalg.norm(r.target_uv - Y, axis=1).max())
    # the pushed vertex lands near where the smooth map has it (linear precision)
    assert np.linalg.norm(r.target_uv[v] - _smooth_map(uv)[v]) < 0.3 * np.linalg.norm(
        Y[v] - _smooth_map(uv)[v]
    )


def test_a_map_that_does_not_fold_is_returned_unchanged():
    uv, F, rim = _disk()
    Y = _smooth_map(uv)
    r = map_fold_repair(uv, Y, F, fixed=rim)
    assert r.repaired and r.rings == 0 and r.moved.size == 0 and r.folded.size == 0
    assert np.array_equal(r.target_uv, Y)


def test_affine_maps_are_reproduced_by_the_re_solve():
    """Mean-value coordinates have linear precision: a fold inside an affine map is
    repaired back onto the affine map itself."""
    uv, F, rim = _disk()
    A = np.array([[1.3, 0.4], [-0.2, 0.8]])
    Y = uv @ A.T + [0.1, -0.3]
    bad = Y.copy()
    v = int(np.flatnonzero(~rim)[5])
    bad[v] += [0.5, 0.5]
    r = map_fold_repair(uv, bad, F, fixed=rim)
    assert r.repaired
    np.testing.assert_allclose(r.target_uv, Y, atol=1e-10)


def test_when_nothing_may_move_the_repair_fails_and_says_so():
    uv, F, rim = _disk()
    Y, _ = _folded(uv, F, rim)
    r = map_fold_repair(uv, Y, F, fixed=np.ones(len(uv), dtype=bool))
    assert not r.repaired and np.array_equal(r.target_uv, Y) and r.folded.size > 0


def test_scale_and_rigid_motion_invariance_and_inputs_untouched():
    uv, F, rim = _disk()
    Y, _ = _folded(uv, F, rim)
    Y0 = Y.copy()
    r = map_fold_repair(uv, Y, F, fixed=rim)
    np.testing.assert_array_equal(Y, Y0)
    R = np.array([[0.0, -1.0], [1.0, 0.0]])
    for s in (1e-8, 1e8):
        rs = map_fold_repair(s * uv @ R.T, s * Y @ R.T + 3 * s, F, fixed=rim)
        assert rs.repaired
        np.testing.assert_array_equal(rs.moved, r.moved)
        np.testing.assert_allclose(
            rs.target_uv, s * r.target_uv @ R.T + 3 * s, rtol=1e-8, atol=1e-8 * s
        )


def test_validation():
    uv, F, rim = _disk(1)
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        map_fold_repair(uv, uv[:-1], F)
    with pytest.raises(ValueError, match="max_rings"):
        map_fold_repair(uv, uv, F, max_rings=0)
    with pytest.raises(ValueError, match="fixed"):
        map_fold_repair(uv, uv, F, fixed=rim[:-1])
