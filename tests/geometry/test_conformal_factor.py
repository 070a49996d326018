import numpy as np
import pytest

from conformorph import geometry as g
from tests.meshes import bumpy_disk, disk_grid


def test_scaled_flat_disk_by_hand():
    V, F = disk_grid(3)
    # uv = V / 2: every one-ring area shrinks by 4, so λ = 4 everywhere
    np.testing.assert_allclose(g.conformal_factor(V, F, V[:, :2] / 2), 4.0, rtol=1e-12)


def test_area_identity_and_invariance():
    V, F = bumpy_disk(6)
    uv, _ = g.disk_conformal_map(V, F)
    lam = g.conformal_factor(V, F, uv)
    assert np.all(lam > 0)
    # λ_i A^uv_i is the 3D barycentric vertex area
    np.testing.assert_allclose(lam * g.vertex_areas(uv, F), g.vertex_areas(V, F), rtol=1e-12)
    np.testing.assert_allclose(g.conformal_factor(3 * V + 1.0, F, uv), 9 * lam, rtol=1e-12)


def test_collapsed_parameterisation_is_an_error():
    V, F = disk_grid(2)
    uv = V[:, :2].copy()
    uv[:] = 0.0
    with pytest.raises(ValueError, match="zero area"):
        g.conformal_factor(V, F, uv)
