import numpy as np

from conformorph import geometry as g
from tests.meshes import disk_grid, random_rotation, spherical_cap


def test_hand_worked_corner_of_a_cube():
    # three unit right triangles meeting at the origin, in the three coordinate planes,
    # oriented so that their normals are +x, +y, +z; equal areas → normal (1,1,1)/√3
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1]])
    np.testing.assert_allclose(g.vertex_normals(V, F)[0], np.ones(3) / np.sqrt(3), atol=1e-15)


def test_flat_mesh_rotation_and_orientation():
    V, F = disk_grid(3)
    N = g.vertex_normals(V, F)
    np.testing.assert_allclose(N, np.tile([0, 0, 1.0], (len(V), 1)), atol=1e-15)
    R = random_rotation(1)
    np.testing.assert_allclose(g.vertex_normals(V @ R.T, F), N @ R.T, atol=1e-12)
    np.testing.assert_allclose(g.vertex_normals(V, F[:, ::-1]), -N, atol=1e-15)


def test_sphere_normals_approach_the_radius_under_refinement():
    errs = []
    for k in (4, 8, 16):
        V, F = spherical_cap(k)
        errs.append(np.abs(np.einsum("ij,ij->i", g.vertex_normals(V, F), V) - 1).max())
    assert errs[0] > errs[1] > errs[2] and errs[2] < 1e-3


def test_cancelling_normals_give_zero():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    F = np.array([[0, 1, 2], [0, 2, 1]])
    np.testing.assert_array_equal(g.vertex_normals(V, F), 0)


def test_rtol_counts_nearly_cancelling_normals_as_zero():
    # the same unit right triangle twice with opposite orientation, the second's
    # apex lifted by 1e-14: at the shared vertices the two normals cancel up to ~1e-14
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 1e-14]], dtype=float)
    F = np.array([[0, 1, 2], [0, 3, 1]])
    exact = g.vertex_normals(V, F)
    assert np.all(np.linalg.norm(exact, axis=1) > 0.99)  # rtol 0: only exact zeros vanish
    N = g.vertex_normals(V, F, rtol=1e-12)
    np.testing.assert_array_equal(N[[0, 1]], 0)
    np.testing.assert_array_equal(N[2:], exact[2:])  # lone vertices keep their unit normals
