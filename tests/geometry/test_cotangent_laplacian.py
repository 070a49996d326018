import numpy as np
import pytest

from conformorph.geometry import cotangent_laplacian
from tests.meshes import bumpy_disk, disk_grid


def test_single_triangle_by_hand():
    # equilateral triangle: every angle 60°, cot = 1/√3, weight = cot/2
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0]])
    L = cotangent_laplacian(V, np.array([[0, 1, 2]])).toarray()
    w = 0.5 / np.sqrt(3)
    expected = np.array([[2 * w, -w, -w], [-w, 2 * w, -w], [-w, -w, 2 * w]])
    np.testing.assert_allclose(L, expected, atol=1e-15)


@pytest.mark.parametrize("mesh", [disk_grid, bumpy_disk])
def test_invariants(mesh):
    V, F = mesh()
    L = cotangent_laplacian(V, F)
    np.testing.assert_allclose(L @ np.ones(len(V)), 0, atol=1e-12)
    np.testing.assert_allclose((L - L.T).toarray(), 0, atol=1e-14)
    assert np.linalg.eigvalsh(L.toarray()).min() > -1e-10


def test_linear_precision_on_flat_mesh():
    V, F = disk_grid(6)
    L = cotangent_laplacian(V, F)
    b = np.hypot(V[:, 0], V[:, 1]) > 1 - 1e-9
    LV = L @ V
    np.testing.assert_allclose(LV[~b], 0, atol=1e-12)


def test_scale_and_rotation_invariance_and_no_mutation():
    V, F = bumpy_disk(6)
    V0 = V.copy()
    L = cotangent_laplacian(V, F).toarray()
    np.testing.assert_array_equal(V, V0)
    R = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    for s in (1e-3, 1e3):
        np.testing.assert_allclose(cotangent_laplacian(s * V @ R.T + 5, F).toarray(), L, atol=1e-9)
