import numpy as np
import pytest

from conformorph.geometry.boundary_loop import boundary_loop, boundary_loops
from conformorph.geometry.double_cover import double_cover
from conformorph.geometry.mesh_edges import mesh_edges
from conformorph.geometry.mesh_errors import NotTrianglesError
from tests.meshes import bumpy_disk, disk_grid


def _square_with_centre():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    return V, F


def test_square_with_centre_by_hand():
    V, F = _square_with_centre()
    dc = double_cover(V, F)
    # one interior vertex (0) gets a twin, the four boundary vertices are shared
    assert dc.V.shape == (6, 3) and dc.F.shape == (8, 3)
    assert dc.twin.tolist() == [5, 1, 2, 3, 4]
    assert dc.source_vertex.tolist() == [0, 1, 2, 3, 4, 0]
    assert dc.second_copy.tolist() == [False] * 5 + [True]
    np.testing.assert_array_equal(dc.F[:4], F)
    # second copy: same triangles through the twin map, reversed orientation
    np.testing.assert_array_equal(dc.F[4:], [[5, 2, 1], [5, 3, 2], [5, 4, 3], [5, 1, 4]])
    np.testing.assert_array_equal(dc.V[5], V[0])


@pytest.mark.parametrize("mesh", [disk_grid, bumpy_disk])
def test_cover_is_closed_oriented_genus_zero(mesh):
    V, F = mesh(6)
    dc = double_cover(V, F)
    n, k = V.shape[0], boundary_loop(F).size
    assert dc.V.shape[0] == 2 * n - k
    E = mesh_edges(dc.F)
    assert np.all(E.face_count == 2)  # closed, manifold
    chi = dc.V.shape[0] - E.edges.shape[0] + dc.F.shape[0]
    assert chi == 2
    assert boundary_loops(dc.F) == []
    # consistently oriented: every directed half-edge occurs exactly once
    he = np.stack([dc.F, np.roll(dc.F, -1, axis=1)], axis=2).reshape(-1, 2)
    assert np.unique(he, axis=0).shape[0] == he.shape[0]
    np.testing.assert_array_equal(dc.V, V[dc.source_vertex])
    assert np.all(dc.twin[dc.b] == dc.b)
    # the mirror swaps the copies: an involution fixing exactly the seam, mapping
    # the triangles of one copy onto those of the other (reversed)
    mir = dc.mirror
    np.testing.assert_array_equal(mir[mir], np.arange(dc.V.shape[0]))
    np.testing.assert_array_equal(np.flatnonzero(mir == np.arange(mir.size)), np.sort(dc.b))
    m = F.shape[0]
    np.testing.assert_array_equal(np.sort(mir[dc.F[:m]], axis=1), np.sort(dc.F[m:], axis=1))


def test_vertex_order_is_kept_and_inputs_not_mutated():
    V, F = bumpy_disk(5)
    V0, F0 = V.copy(), F.copy()
    dc = double_cover(V, F)
    np.testing.assert_array_equal(dc.V[: V.shape[0]], V)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)


def test_given_boundary_is_used():
    V, F = disk_grid(4)
    b = boundary_loop(F)
    np.testing.assert_array_equal(double_cover(V, F, b).b, b)


def test_bad_shapes_raise():
    V, F = _square_with_centre()
    with pytest.raises(NotTrianglesError):
        double_cover(V[:, :2], F)
    with pytest.raises(NotTrianglesError):
        double_cover(V, F.astype(float))
