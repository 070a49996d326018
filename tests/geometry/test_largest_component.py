"""largest_component: the faces of the biggest piece and the sizes of the rest."""

import numpy as np
import pytest

from conformorph.geometry import largest_component
from tests.meshes import disk_grid


def test_hand_case() -> None:
    F = np.array([[7, 8, 9], [0, 1, 2], [1, 3, 2], [2, 3, 4], [10, 11, 12], [10, 12, 13]])
    s = largest_component(F)
    assert s.face_mask.tolist() == [False, True, True, True, False, False]
    assert s.dropped_vertex_counts == [4, 3]
    assert s.dropped_face_counts == [2, 1]


def test_ties_keep_the_first_and_vertex_touch_joins() -> None:
    F = np.array([[3, 4, 5], [0, 1, 2]])
    assert largest_component(F).face_mask.tolist() == [True, False]
    # two triangles touching at one vertex are one component
    assert largest_component(np.array([[0, 1, 2], [2, 3, 4]])).face_mask.all()


def test_grid_plus_fragment_invariant_to_face_order() -> None:
    V, F = disk_grid(4)
    n = V.shape[0]
    frag = np.array([[n, n + 1, n + 2], [n + 1, n + 3, n + 2]])
    F2 = np.vstack([frag, F])
    s = largest_component(F2)
    assert s.face_mask.sum() == F.shape[0] and not s.face_mask[:2].any()
    assert s.dropped_vertex_counts == [4]
    perm = np.random.default_rng(0).permutation(F2.shape[0])
    s2 = largest_component(F2[perm])
    np.testing.assert_array_equal(s2.face_mask, s.face_mask[perm])


def test_failures() -> None:
    with pytest.raises(ValueError):
        largest_component(np.zeros((0, 3), dtype=np.int64))
    with pytest.raises(ValueError):
        largest_component(np.array([[0, 1, -1]]))
    with pytest.raises(ValueError):
        largest_component(np.array([[0.0, 1, 2]]))
