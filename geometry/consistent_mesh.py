"""Consistent meshes on the disk and resampling of per-vertex data (section 4 of the face paper).

"First, a coarse mesh is constructed by connecting the landmarks on the unit
disk using straight line segments on φ0(M0). Then a finer mesh is obtained by
regular mesh refinements for a few times." The nodes of that mesh are carried
to the other disks by the registration maps, and every per-vertex quantity
(H, λ, positions, colours, UVs) of an input mesh is resampled at the carried
nodes by barycentric interpolation in that input's disk map — so the inputs
never need to share connectivity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay

from ._typing import FloatArray, IntArray
from .boundary_loop import boundary_loop
from .flipped_triangles import signed_areas_2d
from .mesh_edges import mesh_edges
from .point_location import PointLocator

#: Two landmarks closer than this on the disk are duplicates (the coarse mesh
#: would get a degenerate triangle).
LANDMARK_MIN_SEPARATION = 1e-6


@dataclass(frozen=True)
class ConsistentMesh:
    """A triangulation of the source disk shared by all key frames.

    Attributes
    ----------
    uv : (n, 2) float64
        Node positions on the source disk :math:`\\varphi_0(M_0)`.
    F : (m, 3) int64
        Counter-clockwise triangles.
    b : (k,) int64
        Boundary loop (nodes on the unit circle), oriented like F.
    levels : int
        Regular refinements applied to the coarse landmark mesh (0 for the
        source-mesh mode).
    mode : str
        ``"landmarks"`` or ``"source"``.
    """

    uv: FloatArray
    F: IntArray
    b: IntArray
    levels: int
    mode: str


def landmark_disk_mesh(
    landmarks_uv: FloatArray, *, n_boundary: int = 32
) -> tuple[FloatArray, IntArray]:
    """Coarse triangulation of the unit disk connecting the landmarks.

    Parameters
    ----------
    landmarks_uv : (m, 2) float64
        Landmarks strictly inside the unit disk.
    n_boundary : int, default 32
        Nodes placed evenly on the unit circle (angle 0 first).

    Returns
    -------
    uv : (m + n_boundary, 2) float64
        The landmarks first (in their order), then the circle nodes.
    F : (f, 3) int64
        Delaunay triangles, counter-clockwise.

    Raises
    ------
    ValueError
        If a landmark is not strictly inside the disk or two landmarks coincide.
    """
    P = np.asarray(landmarks_uv, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 1 or not np.all(np.isfinite(P)):
        raise ValueError(f"landmarks_uv must be a finite (m, 2) array, got {P.shape}")
    if n_boundary < 3:
        raise ValueError(f"n_boundary must be ≥ 3, got {n_boundary}")
    if np.any(np.hypot(P[:, 0], P[:, 1]) >= 1.0 - 1e-9):
        raise ValueError("landmarks must lie strictly inside the unit disk")
    d = np.linalg.norm(P[:, None] - P[None], axis=2) + np.eye(P.shape[0])
    if d.min() < LANDMARK_MIN_SEPARATION:
        i, j = np.unravel_index(np.argmin(d), d.shape)
        raise ValueError(f"landmarks {i} and {j} coincide on the disk")
    ang = 2 * np.pi * np.arange(n_boundary) / n_boundary
    uv = np.vstack([P, np.c_[np.cos(ang), np.sin(ang)]])
    F = np.asarray(Delaunay(uv).simplices, dtype=np.int64)
    a = signed_areas_2d(uv, F)
    F[a < 0] = F[a < 0][:, [0, 2, 1]]
    F = F[np.abs(a) > 1e-14]
    return uv, F


def refine_disk_mesh(uv: FloatArray, F: IntArray, levels: int) -> tuple[FloatArray, IntArray]:
    """Regular (1 → 4) refinement of a disk triangulation, boundary midpoints put on the circle.

    Parameters
    ----------
    uv : (n, 2) float64
        Nodes; boundary nodes on the unit circle.
    F : (m, 3) int64
        Counter-clockwise triangles of a disk.
    levels : int
        Number of refinements (≥ 0).

    Returns
    -------
    uv : (n', 2) float64
        The old nodes first (same order), then edge midpoints.
    F : (4^levels m, 3) int64
    """
    if levels < 0:
        raise ValueError(f"levels must be ≥ 0, got {levels}")
    uv = np.asarray(uv, dtype=np.float64).copy()
    F = np.asarray(F, dtype=np.int64).copy()
    for _ in range(levels):
        E = mesh_edges(F)
        n = uv.shape[0]
        mid = 0.5 * (uv[E.edges[:, 0]] + uv[E.edges[:, 1]])
        on_b = E.face_count == 1
        mid[on_b] /= np.linalg.norm(mid[on_b], axis=1, keepdims=True)
        uv = np.vstack([uv, mid])
        e = n + E.halfedge_edge  # (m, 3): midpoint of edge (F[:, j], F[:, j+1])
        a, b_, c = F[:, 0], F[:, 1], F[:, 2]
        ab, bc, ca = e[:, 0], e[:, 1], e[:, 2]
        F = np.vstack(
            [np.c_[a, ab, ca], np.c_[ab, b_, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]]
        ).astype(np.int64)
    return uv, F


def refinement_levels(n_coarse_vertices: int, n_coarse_faces: int, target_vertices: int) -> int:
    """Smallest number of regular refinements giving at least ``target_vertices`` nodes.

    Parameters
    ----------
    n_coarse_vertices, n_coarse_faces : int
        Size of the coarse disk mesh.
    target_vertices : int
        Requested resolution.

    Returns
    -------
    int

    Notes
    -----
    For a disk, V − E + F = 1, so E = V + F − 1; one refinement gives
    V' = V + E and F' = 4F.
    """
    v, f, k = n_coarse_vertices, n_coarse_faces, 0
    while v < target_vertices and k < 12:
        v, f, k = v + (v + f - 1), 4 * f, k + 1
    return k


def consistent_mesh(
    source_uv: FloatArray,
    source_F: IntArray,
    landmarks_uv: FloatArray,
    *,
    mode: str = "landmarks",
    target_vertices: int | None = None,
    levels: int | None = None,
    n_boundary: int = 32,
) -> ConsistentMesh:
    """Build the consistent mesh on the source disk.

    Parameters
    ----------
    source_uv : (n0, 2) float64
        Disk map of the source surface.
    source_F : (m0, 3) int64
        Its triangles.
    landmarks_uv : (m, 2) float64
        Source landmarks on the disk.
    mode : {"landmarks", "source"}, default "landmarks"
        ``"landmarks"``: the paper's coarse mesh connecting the landmarks (plus
        ``n_boundary`` circle nodes), refined ``levels`` times; ``"source"``:
        the source disk mesh itself.
    target_vertices : int, optional
        With ``mode="landmarks"`` and no ``levels``: refine until at least this
        many nodes (default: the source vertex count).
    levels : int, optional
        Explicit number of refinements.
    n_boundary : int, default 32
        Circle nodes of the coarse mesh.

    Returns
    -------
    ConsistentMesh
    """
    src_uv = np.asarray(source_uv, dtype=np.float64)
    src_F = np.asarray(source_F, dtype=np.int64)
    if mode == "source":
        return ConsistentMesh(src_uv.copy(), src_F.copy(), boundary_loop(src_F), 0, "source")
    if mode != "landmarks":
        raise ValueError(f"mode must be 'landmarks' or 'source', got {mode!r}")
    uv, F = landmark_disk_mesh(landmarks_uv, n_boundary=n_boundary)
    if levels is None:
        tv = src_uv.shape[0] if target_vertices is None else int(target_vertices)
        levels = refinement_levels(uv.shape[0], F.shape[0], tv)
    uv, F = refine_disk_mesh(uv, F, levels)
    return ConsistentMesh(uv, F, boundary_loop(F), int(levels), "landmarks")


def resample_vertex_data(
    disk_uv: FloatArray,
    F: IntArray,
    values: FloatArray,
    points: FloatArray,
    *,
    locator: PointLocator | None = None,
) -> FloatArray:
    """Resample per-vertex data of a disk-parameterised mesh at points of its disk.

    Parameters
    ----------
    disk_uv : (n, 2) float64
        Disk map of the mesh the data lives on.
    F : (m, 3) int64
        Its triangles.
    values : (n,) or (n, d) float64
        Per-vertex data (H, λ, 3D positions, colours, UVs, ...).
    points : (p, 2) float64
        Where to sample (e.g. consistent-mesh nodes carried by a registration map).
    locator : PointLocator, optional
        Prepared locator for (disk_uv, F), reused if given.

    Returns
    -------
    (p,) or (p, d) float64
        Barycentric interpolation (points outside the polygonal disk are
        snapped to its nearest point).
    """
    vals = np.asarray(values, dtype=np.float64)
    if vals.shape[0] != np.asarray(disk_uv).shape[0]:
        raise ValueError(
            f"values have {vals.shape[0]} rows, disk_uv has {np.asarray(disk_uv).shape[0]}"
        )
    loc = (locator or PointLocator(disk_uv, F)).locate(points)
    return loc.interpolate(np.asarray(F, dtype=np.int64), vals)
