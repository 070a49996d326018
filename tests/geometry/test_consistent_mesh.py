import numpy as np
import pytest

from geometry.consistent_mesh import (
    consistent_mesh,
    landmark_disk_mesh,
    refine_disk_mesh,
    refinement_levels,
    resample_vertex_data,
)
from geometry.flipped_triangles import signed_areas_2d

P = np.array([[0.1, 0.2], [-0.3, 0.1], [0.2, -0.4], [0.0, 0.5]])


def test_hand_worked_coarse_mesh():
    uv, F = landmark_disk_mesh(P, n_boundary=4)
    assert uv.shape == (8, 2)
    np.testing.assert_array_equal(uv[:4], P)  # landmarks are nodes, in order
    # disk triangulation of 8 points, 4 on the hull: F = 2n - h - 2 = 10
    assert F.shape == (10, 3)
    assert (signed_areas_2d(uv, F) > 0).all()


def test_refinement_counts_and_circle():
    uv, F = landmark_disk_mesh(P, n_boundary=8)
    for k in range(4):
        u2, F2 = refine_disk_mesh(uv, F, k)
        assert F2.shape[0] == 4**k * F.shape[0]
        assert refinement_levels(uv.shape[0], F.shape[0], u2.shape[0]) == k
        assert (signed_areas_2d(u2, F2) > 0).all()
        r = np.linalg.norm(u2, axis=1)
        assert r.max() <= 1 + 1e-12
        # Euler characteristic of a disk
        E = {tuple(sorted(e)) for f in F2 for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
        assert u2.shape[0] - len(E) + F2.shape[0] == 1
    cm = consistent_mesh(uv, F, P, levels=2)
    np.testing.assert_allclose(np.linalg.norm(cm.uv[cm.b], axis=1), 1.0, atol=1e-12)
    assert cm.b.size == 32 * 4  # default n_boundary = 32, doubled twice


def test_resampling_reproduces_linear_data_and_source_mode():
    src_uv, src_F = refine_disk_mesh(*landmark_disk_mesh(P, n_boundary=10), 3)
    cm = consistent_mesh(src_uv, src_F, P, target_vertices=500)
    assert cm.uv.shape[0] >= 500
    vals = np.c_[2 * src_uv[:, 0] - src_uv[:, 1], src_uv[:, 1] + 3]
    out = resample_vertex_data(src_uv, src_F, vals, cm.uv)
    ref = np.c_[2 * cm.uv[:, 0] - cm.uv[:, 1], cm.uv[:, 1] + 3]
    inside = np.linalg.norm(cm.uv, axis=1) < 0.95
    np.testing.assert_allclose(out[inside], ref[inside], atol=1e-12)
    cs = consistent_mesh(src_uv, src_F, P, mode="source")
    np.testing.assert_array_equal(cs.F, src_F)
    with pytest.raises(ValueError):
        consistent_mesh(src_uv, src_F, P, mode="other")


def test_errors_and_no_mutation():
    P0 = P.copy()
    landmark_disk_mesh(P)
    np.testing.assert_array_equal(P, P0)
    with pytest.raises(ValueError, match="coincide"):
        landmark_disk_mesh(np.vstack([P, P[:1]]))
    with pytest.raises(ValueError, match="inside"):
        landmark_disk_mesh(np.array([[1.0, 0.0]]))
