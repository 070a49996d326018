"""split_nonmanifold: extra faces of over-used edges dropped, pinched vertices split."""

import numpy as np
import pytest

from conformorph.geometry import mesh_edges, split_nonmanifold
from tests.meshes import disk_grid


def test_bow_tie_hand_case() -> None:
    s = split_nonmanifold(np.array([[0, 1, 2], [0, 3, 4]]))
    assert s.F.tolist() == [[0, 1, 2], [5, 3, 4]]
    assert s.source.tolist() == [0, 1, 2, 3, 4, 0]
    assert (s.split_vertices, s.dropped_faces) == (1, 0)


def test_fin_keeps_first_two_faces() -> None:
    s = split_nonmanifold(np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    assert s.F.tolist() == [[0, 1, 2], [1, 0, 3]]
    assert s.face_kept.tolist() == [True, True, False] and s.dropped_faces == 1


def test_manifold_mesh_unchanged() -> None:
    V, F = disk_grid(4)
    s = split_nonmanifold(F)
    np.testing.assert_array_equal(s.F, F)
    np.testing.assert_array_equal(s.source, np.arange(V.shape[0]))


def test_two_disks_pinched_become_valid_pieces() -> None:
    V, F = disk_grid(3)
    n = V.shape[0]
    # a second copy shifted so that its vertex 0 (centre) is glued to a boundary vertex b
    b = int(np.argmax(V[:, 0]))
    V2 = np.vstack([V, V[1:] + V[b] - V[0] + [0, 0, 0.5]])
    G = F + n - 1
    G[F == 0] = b
    s = split_nonmanifold(np.vstack([F, G]), V2.shape[0])
    assert s.split_vertices == 1 and s.source[-1] == b
    from conformorph.geometry.validate_mesh import _nonmanifold_vertices

    W = V2[s.source]
    assert _nonmanifold_vertices(s.F, W.shape[0], mesh_edges(s.F)).size == 0
    # the larger fan keeps b: the first disk's boundary vertex has few faces, the
    # second disk's centre 6, so the glued disk keeps b and the first gets the copy
    assert (s.F[: F.shape[0]] == W.shape[0] - 1).any()
    assert (s.F[F.shape[0] :] == b).sum() == 6
    np.testing.assert_array_equal(W[s.F], V2[np.vstack([F, G])])


def test_failures() -> None:
    with pytest.raises(ValueError, match="repeats"):
        split_nonmanifold(np.array([[0, 0, 1]]))
    with pytest.raises(ValueError, match="outside"):
        split_nonmanifold(np.array([[0, 1, 5]]), 3)
    with pytest.raises(ValueError):
        split_nonmanifold(np.zeros((0, 3), dtype=np.int64))
