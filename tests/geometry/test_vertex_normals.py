import numpy as np
import pytest

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


def _add_at_normals(V, F):
    """The definition, spelled with np.add.at (corner 0 of every face first)."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    length = np.linalg.norm(N, axis=1, keepdims=True)
    return np.divide(N, length, out=np.zeros_like(N), where=length > 0)


def test_blocks_and_frames_give_the_bits_of_the_definition(monkeypatch):
    """Face normals formed in blocks (here of 7 triangles, so many blocks and a ragged
    last one) and a VertexNormals reused over frames: bitwise the np.add.at sums."""
    import importlib

    vn = importlib.import_module("conformorph.geometry.vertex_normals")  # the module
    monkeypatch.setattr(vn, "_BLOCK", 7)
    rng = np.random.default_rng(4)
    F = rng.integers(0, 60, size=(100, 3))
    frames = rng.normal(size=(4, 60, 3))
    normals = vn.VertexNormals(F, 60)
    for V in frames:
        want = _add_at_normals(V, F)
        assert np.array_equal(normals(V), want)
        assert np.array_equal(vn.vertex_normals(V, F), want)


def test_vertex_normals_of_frames_check_their_inputs():
    from conformorph.geometry.vertex_normals import VertexNormals

    with pytest.raises(ValueError, match="outside 0..3"):
        VertexNormals(np.array([[0, 1, 4]]), 4)
    with pytest.raises(ValueError, match=r"\(m, 3\)"):
        VertexNormals(np.array([0, 1, 2]), 3)
    with pytest.raises(ValueError, match=r"V must be \(3, 3\)"):
        VertexNormals(np.array([[0, 1, 2]]), 3)(np.zeros((4, 3)))
