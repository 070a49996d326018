"""Mean curvature and its vector (face paper, section 2.3; Meyer et al. 2003)."""

import numpy as np

from conformorph import geometry as g
from tests.meshes import bumpy_disk, disk_grid, random_rotation, spherical_cap


def _interior(F, n):
    return np.setdiff1d(np.arange(n), g.boundary_loop(F))


def test_plane_has_zero_curvature_and_boundary_rows_are_zero():
    V, F = disk_grid(5)
    np.testing.assert_allclose(g.mean_curvature_vector(V, F), 0, atol=1e-13)
    V, F = spherical_cap(6)
    Hn = g.mean_curvature_vector(V, F)
    assert np.all(Hn[g.boundary_loop(F)] == 0)


def test_regular_hexagon_fan_by_hand():
    # a pyramid over a regular hexagon: apex at height h; by symmetry L V at the apex
    # points along -z, and Hn = (L V)_apex / (2 A_apex) with the barycentric area
    t = np.arange(6) * np.pi / 3
    h = 0.3
    V = np.vstack([[0, 0, h], np.column_stack([np.cos(t), np.sin(t), np.zeros(6)])])
    F = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)])
    Hn = g.mean_curvature_vector(V, F)[0]
    # each face: apex angle edges of length l = sqrt(1 + h²), base 1; the cotangent weight of
    # the spoke (0, j) is (cot β + cot β)/2 with β the base angle of the isosceles face
    side = np.hypot(1.0, h)
    beta = np.arccos(0.5 / side)
    w = 1.0 / np.tan(beta)  # (cot β + cot β) / 2 per spoke
    LV = 6 * w * np.array([0, 0, h])  # Σ_j w (x_0 − x_j): the in-plane parts cancel
    area = 6 * 0.5 * side * np.sqrt(1 - (0.5 / side) ** 2) / 3
    np.testing.assert_allclose(Hn, LV / (2 * area), rtol=1e-12, atol=1e-14)


def test_sphere_converges_to_inverse_radius_under_refinement():
    errors = []
    for k in (6, 12, 24):
        V, F = spherical_cap(k, height=0.8)
        H = g.mean_curvature(V, F)[_interior(F, len(V))]
        errors.append(np.abs(np.abs(H) - 1.0).mean())
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 5e-3


def test_invariant_to_rigid_motion_and_scales_as_inverse_length():
    V, F = bumpy_disk(8)
    H = g.mean_curvature(V, F)
    R = random_rotation(3)
    np.testing.assert_allclose(g.mean_curvature(V @ R.T + [1.0, -2.0, 5.0], F), H, atol=1e-10)
    np.testing.assert_allclose(g.mean_curvature(2.5 * V, F), H / 2.5, rtol=1e-10, atol=1e-12)


def test_sign_follows_face_orientation_and_magnitude_keeps_the_vector():
    V, F = bumpy_disk(8)
    H = g.mean_curvature(V, F)
    np.testing.assert_allclose(g.mean_curvature(V, F[:, ::-1]), -H, atol=1e-12)
    np.testing.assert_allclose(np.abs(H), np.linalg.norm(g.mean_curvature_vector(V, F), axis=1))
