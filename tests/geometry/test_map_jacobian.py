import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.map_jacobian import fold_report, map_jacobian_determinants


def _disk(levels=2):
    uv, F = landmark_disk_mesh(np.array([[0.1, 0.2], [-0.3, 0.1], [0.2, -0.4]]), n_boundary=8)
    return refine_disk_mesh(uv, F, levels)


def test_hand_worked_affine_map():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    A = np.array([[2.0, 1.0], [0.0, 3.0]])
    det = map_jacobian_determinants(uv, uv @ A.T, np.array([[0, 1, 2]]))
    np.testing.assert_allclose(det, [6.0])


def test_affine_map_has_constant_determinant_and_fold_detection():
    uv, F = _disk()
    A = np.array([[1.2, 0.3], [-0.1, 0.9]])
    det = map_jacobian_determinants(uv, uv @ A.T + 0.1, F)
    np.testing.assert_allclose(det, np.linalg.det(A))
    rep = fold_report(uv, uv @ A.T, F)
    assert rep.is_bijective and rep.n_folded == 0
    # a reflection folds everything
    rep = fold_report(uv, uv * [1.0, -1.0], F)
    assert rep.n_folded == F.shape[0] and rep.min_jacobian_determinant < 0
    # moving one interior vertex across its ring folds only nearby triangles
    tgt = uv.copy()
    v = int(np.argmin(np.linalg.norm(uv, axis=1)))
    tgt[v] += [3.0, 0.0]
    rep = fold_report(uv, tgt, F)
    assert 0 < rep.n_folded < 10
    assert set(rep.folded_triangles.tolist()) <= set(np.nonzero((F == v).any(axis=1))[0].tolist())


def test_source_flips_are_excluded_and_inputs_not_mutated():
    uv, F = _disk(1)
    F2 = F.copy()
    F2[0] = F2[0, [0, 2, 1]]
    uv0 = uv.copy()
    rep = fold_report(uv, uv, F2)
    assert rep.n_source_flipped == 1 and rep.n_folded == 0
    np.testing.assert_array_equal(uv, uv0)
    with pytest.raises(ValueError):
        map_jacobian_determinants(uv, uv[:-1], F)
