import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.registration_error import (
    disk_registration_error,
    surface_registration_error,
)


def test_hand_worked_disk_error():
    a = np.array([[0.0, 0.0], [0.3, 0.0]])
    b = np.array([[0.0, 0.4], [0.0, 0.0]])
    assert disk_registration_error(a, b) == pytest.approx(0.5)
    assert disk_registration_error(a, a) == 0.0
    with pytest.raises(ValueError):
        disk_registration_error(a, b[:1])


def test_surface_error_on_a_paraboloid():
    uv, F = landmark_disk_mesh(np.array([[0.0, 0.0]]), n_boundary=16)
    uv, F = refine_disk_mesh(uv, F, 4)
    V = np.c_[2 * uv, (uv**2).sum(axis=1)]  # φ⁻¹(u) = (2u, |u|²)
    q = np.array([[0.1, 0.2], [-0.3, 0.0]])
    Y = np.c_[2 * q, (q**2).sum(axis=1)]
    # the identity map: E = 0 up to interpolation error of |u|²
    assert surface_registration_error(q, uv, V, F, Y) < 3e-3
    # a disk offset δ of both points maps to ≈ 2δ in 3D (plus the z change)
    d = np.array([0.01, 0.0])
    e = surface_registration_error(q + d, uv, V, F, Y)
    assert e == pytest.approx(np.sqrt(2) * 0.02, rel=0.05)
    uv0 = uv.copy()
    surface_registration_error(q, uv, V, F, Y)
    np.testing.assert_array_equal(uv, uv0)
