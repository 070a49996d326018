"""clean_mesh_elements: degenerate and duplicate faces, unreferenced vertices."""

import numpy as np
import pytest

from conformorph.geometry import clean_mesh_elements, validate_mesh
from conformorph.geometry.mesh_errors import (
    FaceIndexOutOfRangeError,
    MeshError,
    NonFiniteCoordinatesError,
)
from tests.meshes import disk_grid


def test_hand_case_counts_and_order() -> None:
    V = np.array([[0.0, 0, 0], [9, 9, 9], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 2, 0]])
    F = np.array([[0, 2, 3], [3, 2, 0], [2, 4, 3], [0, 0, 2], [0, 2, 5], [2, 3, 2]])
    # face 4: (0, 2, 5) has area 1 (not degenerate); 5 is (2,2,0)
    c = clean_mesh_elements(V, F)
    assert c.duplicate_faces == 1  # (3, 2, 0) repeats (0, 2, 3) reversed
    assert c.degenerate_faces == 2  # (0, 0, 2) and (2, 3, 2)
    assert c.unreferenced_vertices == 1  # vertex 1
    assert c.kept.tolist() == [0, 2, 3, 4, 5]
    np.testing.assert_array_equal(c.V, V[c.kept])
    np.testing.assert_array_equal(c.kept[c.F], F[[0, 2, 4]])


def test_zero_area_faces_are_degenerate_and_nan_is_refused() -> None:
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [5, 0, 0]])
    F = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 4]])  # collinear 0, 1, 3
    c = clean_mesh_elements(V, F)
    assert c.degenerate_faces == 1 and c.unreferenced_vertices == 1
    assert c.F.tolist() == [[0, 1, 2], [0, 2, 3]] and c.kept.tolist() == [0, 1, 2, 4]
    V[4, 0] = np.nan
    with pytest.raises(NonFiniteCoordinatesError, match="vertices \\[4\\]"):
        clean_mesh_elements(V, F)


def test_clean_mesh_unchanged_and_passes_validation() -> None:
    V, F = disk_grid(4)
    c = clean_mesh_elements(V, F)
    np.testing.assert_array_equal(c.F, F)
    np.testing.assert_array_equal(c.V, V)
    assert (c.degenerate_faces, c.duplicate_faces, c.unreferenced_vertices) == (0, 0, 0)
    validate_mesh(c.V, c.F, require_disk=True)


def test_scale_invariant_and_inputs_not_mutated() -> None:
    V, F = disk_grid(3)
    F2 = np.vstack([F, F[:3], [[0, 0, 1]]])
    V2 = np.vstack([V, [[5.0, 5, 5]]])
    before = (V2.copy(), F2.copy())
    for s in (1e-8, 1.0, 1e8):
        c = clean_mesh_elements(V2 * s, F2)
        assert (c.degenerate_faces, c.duplicate_faces, c.unreferenced_vertices) == (1, 3, 1)
    np.testing.assert_array_equal(V2, before[0])
    np.testing.assert_array_equal(F2, before[1])


def test_failures() -> None:
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(FaceIndexOutOfRangeError):
        clean_mesh_elements(V, [[0, 1, 3]])
    with pytest.raises(MeshError, match="no face is left"):
        clean_mesh_elements(V, [[0, 0, 1]])
    with pytest.raises(MeshError):
        clean_mesh_elements(V[:, :2], [[0, 1, 2]])
