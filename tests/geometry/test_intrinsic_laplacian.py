import numpy as np
import pytest

from conformorph.geometry import cotangent_laplacian, vertex_areas
from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.intrinsic_laplacian import edge_lengths, intrinsic_cotangent_laplacian


def _surface(levels=2):
    uv, F = refine_disk_mesh(*landmark_disk_mesh(np.array([[0.1, -0.2]]), n_boundary=10), levels)
    return np.c_[uv, 0.3 * np.sin(2 * uv[:, 0]) * np.cos(uv[:, 1])], F


def test_hand_worked_right_triangle():
    L, A, bad = intrinsic_cotangent_laplacian(
        np.array([[0, 1, 2]]), np.array([1.0, 1.0, np.sqrt(2.0)])
    )
    np.testing.assert_allclose(
        L.toarray(), [[1, -0.5, -0.5], [-0.5, 0.5, 0], [-0.5, 0, 0.5]], atol=1e-12
    )
    np.testing.assert_allclose(A, [1 / 6] * 3)
    assert bad == 0


def test_matches_embedded_laplacian_and_is_rigid_invariant():
    V, F = _surface()
    L, A, bad = intrinsic_cotangent_laplacian(F, edge_lengths(V, F))
    L0 = cotangent_laplacian(V, F)
    assert abs(L - L0).max() < 1e-12 * abs(L0).max()
    np.testing.assert_allclose(A, vertex_areas(V, F), rtol=1e-12)
    np.testing.assert_allclose(L @ np.ones(V.shape[0]), 0, atol=1e-12)
    R = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    L2, _, _ = intrinsic_cotangent_laplacian(F, edge_lengths(V @ R.T + 4.0, F))
    assert abs(L2 - L).max() < 1e-10
    # scaling lengths leaves cotangents unchanged, scales areas quadratically
    L3, A3, _ = intrinsic_cotangent_laplacian(F, 1e3 * edge_lengths(V, F))
    assert abs(L3 - L).max() < 1e-9
    np.testing.assert_allclose(A3, 1e6 * A, rtol=1e-10)


def test_triangle_inequality_violations_are_clamped_and_counted():
    L, A, bad = intrinsic_cotangent_laplacian(np.array([[0, 1, 2]]), np.array([1.0, 1.0, 3.0]))
    assert bad == 1 and np.all(np.isfinite(L.toarray())) and np.all(A >= 0)


def test_validation_and_no_mutation():
    V, F = _surface(1)
    ell = edge_lengths(V, F)
    e0 = ell.copy()
    intrinsic_cotangent_laplacian(F, ell)
    np.testing.assert_array_equal(ell, e0)
    with pytest.raises(ValueError):
        intrinsic_cotangent_laplacian(F, ell[:-1])
    with pytest.raises(ValueError):
        intrinsic_cotangent_laplacian(F, -ell)


def test_pattern_blocks_match_the_full_laplacian():
    from conformorph.geometry import boundary_loop
    from conformorph.geometry.intrinsic_laplacian import IntrinsicLaplacianPattern

    V, F = _surface(2)
    b = boundary_loop(F)
    pat = IntrinsicLaplacianPattern(F, b)
    for scale in (1.0, 2.5):
        ell = scale * edge_lengths(V, F)
        L, A, _ = intrinsic_cotangent_laplacian(F, ell)
        L_II, L_IB, A2, bad = pat.blocks(ell)
        inner = pat.interior
        assert abs(L_II - L[inner][:, inner]).max() < 1e-12
        assert abs(L_IB - L[inner][:, b]).max() < 1e-12
        np.testing.assert_allclose(A2, A)
        assert bad == 0
