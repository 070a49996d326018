"""The shared face-array check of the mesh-repair steps."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.geometry._face_array import face_array, faces_and_vertex_count


def test_hand_worked_case_gives_int64_and_the_vertex_count():
    F = np.array([[0, 1, 2], [2, 1, 3]], dtype=np.int32)
    G, n = faces_and_vertex_count(F, None)
    assert G.dtype == np.int64 and G.tolist() == F.tolist() and n == 4
    assert faces_and_vertex_count(F, 6)[1] == 6


@pytest.mark.parametrize(
    "F", [np.zeros((0, 3), int), np.zeros((2, 4), int), np.zeros(3, int), np.zeros((1, 3))]
)
def test_shape_and_dtype_are_checked(F):
    with pytest.raises(ValueError, match=r"non-empty \(m, 3\) integer array"):
        face_array(F)


@pytest.mark.parametrize("F, n", [([[0, 1, -1]], None), ([[0, 1, 4]], 4)])
def test_indices_outside_the_vertices_are_refused(F, n):
    with pytest.raises(ValueError, match="outside"):
        faces_and_vertex_count(np.array(F), n)


def test_input_is_not_changed_nor_returned():
    F = np.array([[0, 1, 2]], dtype=np.int64)
    G = face_array(F)
    G[0, 0] = 5
    assert F.tolist() == [[0, 1, 2]]
