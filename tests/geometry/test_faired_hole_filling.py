"""fill_holes_faired, hole_patch_faces, patch_rings."""

import numpy as np
import pytest

from conformorph.geometry import (
    clean_mesh_elements,
    disk_conformal_map,
    fill_holes_faired,
    hole_patch_faces,
    mesh_edges,
    patch_rings,
    validate_mesh,
)
from tests.meshes import disk_grid, spherical_cap


def _cut(V: np.ndarray, F: np.ndarray, centre: np.ndarray, radius: float) -> tuple:
    """Remove the faces whose centroid lies within ``radius`` of ``centre`` (and the
    vertices no face uses then)."""
    keep = np.linalg.norm(V[F].mean(axis=1) - centre, axis=1) >= radius
    c = clean_mesh_elements(V, F[keep])
    return c.V, c.F


def test_patch_faces_hand_case() -> None:
    faces, added = hole_patch_faces(np.array([0, 1, 2]), 3, [])
    assert faces.tolist() == [[1, 0, 3], [2, 1, 3], [0, 2, 3]] and added == 1
    faces, added = hole_patch_faces(np.arange(8), 8, [4])
    assert added == 5 and faces.shape == (8 + 4 + 4, 3)
    # every loop edge is used once by the patch, reversed (continues the orientation)
    loop_edges = {(int((i + 1) % 8), int(i)) for i in range(8)}
    assert loop_edges <= {(int(f[0]), int(f[1])) for f in faces}


def test_patch_rings() -> None:
    assert patch_rings(6) == [] and patch_rings(3) == []
    sizes = patch_rings(64)
    assert sizes == sorted(sizes, reverse=True) and min(sizes) >= 3 and len(sizes) == 9


def test_flat_hole_filled_in_plane_and_valid_disk() -> None:
    V, F = disk_grid(8)
    V, F = _cut(V, F, np.array([0.3, 0.1, 0.0]), 0.25)
    validate_mesh(V, F, require_disk=False, allow_ears=True)
    res = fill_holes_faired(V, F)
    assert len(res.filled_loop_sizes) == 1 and res.unfilled_loop_sizes == []
    np.testing.assert_array_equal(res.V[: V.shape[0]], V)
    np.testing.assert_array_equal(res.F[: F.shape[0]], F)
    np.testing.assert_allclose(res.V[V.shape[0] :, 2], 0, atol=1e-12)
    validate_mesh(res.V, res.F, require_disk=True, allow_ears=True)  # the grid has ears
    uv, info = disk_conformal_map(res.V, res.F)
    assert info.flipped == 0


def test_curved_hole_follows_the_sphere_rigid_and_scale_invariant() -> None:
    V, F = spherical_cap(12, 0.6)
    V, F = _cut(V, F, np.array([0.0, 0.0, 1.0]), 0.35)
    res = fill_holes_faired(V, F)
    new = res.V[V.shape[0] :]
    err = np.abs(np.linalg.norm(new, axis=1) - 1).max()
    # the flat fan's centre (the loop centroid) is far below the sphere
    loop_rows = np.unique(mesh_edges(F).boundary)
    inner = loop_rows[np.linalg.norm(V[loop_rows, :2], axis=1) < 0.5]
    flat = 1 - np.linalg.norm(V[inner].mean(axis=0))
    assert err < 0.2 * flat
    rng = np.random.default_rng(1)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    for s in (1e-8, 1e8):
        moved = fill_holes_faired(s * V @ Q.T + 3 * s, F)
        np.testing.assert_allclose(moved.V, s * res.V @ Q.T + 3 * s, rtol=1e-9, atol=1e-9 * s)
        np.testing.assert_array_equal(moved.F, res.F)


def test_large_loops_stay_open_and_inputs_not_mutated() -> None:
    V, F = disk_grid(8)
    V, F = _cut(V, F, np.array([0.0, 0.0, 0.0]), 0.6)
    before = (V.copy(), F.copy())
    res = fill_holes_faired(V, F, max_hole_fraction=0.5)
    assert res.filled_loop_sizes == [] and len(res.unfilled_loop_sizes) == 1
    assert res.V.shape == V.shape
    filled = fill_holes_faired(V, F, max_hole_fraction=1.0)
    assert len(filled.filled_loop_sizes) == 1
    np.testing.assert_array_equal(V, before[0])
    np.testing.assert_array_equal(F, before[1])


def test_failures() -> None:
    V, F = disk_grid(2)
    with pytest.raises(ValueError, match="max_hole_fraction"):
        fill_holes_faired(V, F, max_hole_fraction=0.0)
    # a closed tetrahedron has no boundary
    T = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    closed = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    with pytest.raises(ValueError, match="no boundary"):
        fill_holes_faired(T, closed)
    with pytest.raises(ValueError):
        hole_patch_faces(np.array([0, 1]), 2, [])
    with pytest.raises(ValueError):
        hole_patch_faces(np.arange(5), 5, [2])
