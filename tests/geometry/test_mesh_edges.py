import numpy as np
import pytest

from conformorph import geometry as g
from conformorph.geometry.mesh_errors import NotDiskError
from tests.meshes import disk_grid


def _square():
    # two triangles sharing the diagonal 0–2
    return np.array([[0, 1, 2], [0, 2, 3]])


def test_edges_of_a_square_by_hand():
    E = g.mesh_edges(_square())
    np.testing.assert_array_equal(E.edges, [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3]])
    np.testing.assert_array_equal(E.face_count, [1, 2, 1, 1, 1])
    np.testing.assert_array_equal(E.boundary, [[0, 1], [0, 3], [1, 2], [2, 3]])
    # half-edge (F[f,k], F[f,k+1]) points at its undirected edge
    np.testing.assert_array_equal(E.halfedge_edge, [[0, 3, 1], [1, 4, 2]])


def test_boundary_loop_order_and_orientation():
    F = _square()
    np.testing.assert_array_equal(
        np.roll(g.boundary_loop(F), -int(np.argmin(g.boundary_loop(F)))), [0, 1, 2, 3]
    )
    # reversing the faces reverses the loop (interior stays on the left)
    b = g.boundary_loop(F[:, ::-1])
    np.testing.assert_array_equal(np.roll(b[::-1], -int(np.argmin(b[::-1]))), [0, 1, 2, 3])


def test_euler_characteristic_invariant_on_a_disk():
    V, F = disk_grid(4)
    E = g.mesh_edges(F)
    assert len(V) - len(E.edges) + len(F) == 1
    assert len(g.boundary_loop(F)) == len(E.boundary) == 24


def test_several_loops_need_positions_and_closed_meshes_have_none():
    V, F = disk_grid(3)
    # an annulus: drop the faces at the centre vertex
    ring = F[~np.any(F == 0, axis=1)]
    loops = g.boundary_loops(ring)
    assert [len(x) for x in loops] == [18, 6]
    with pytest.raises(NotDiskError, match="2 boundary loops"):
        g.boundary_loop(ring)
    np.testing.assert_array_equal(g.boundary_loop(ring, V), loops[0])
    tet = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    with pytest.raises(NotDiskError, match="closed"):
        g.boundary_loop(tet)
