"""Landmark files for the face morph: reading, validation and snapping to the surface.

Format (one list per input mesh, in input order, the same count m ≥ 3 each)::

    {"landmarks": [[12, 40, [0.1, 2.0, 3.5], ...], [...], ...]}

Each entry is a 0-based vertex index or an ``[x, y, z]`` point, which is
snapped to the nearest point of the surface (the snap distance is reported;
a point farther than ``max_snap_distance`` — by default 5 % of the mesh's
bounding-box diagonal — is rejected).

The landmark files in ``../shared/data/faces`` are accepted directly:

* ``ict_landmarks68.json`` (key ``landmarks_multipie68_0based``: one list of
  vertex ids valid for every ICT mesh) — the list is used for every input;
* ``meshmonk_landmarks.json`` (key ``nearest_vertex_0based``) likewise;
* ``choi_mcq_landmarks.json`` (keys ``face1``, ``face2``, …, each with
  ``interior_landmarks_0based`` and ``boundary_landmarks_0based_per_loop``):
  the interior landmarks plus those of the inner loops (eye and mouth
  corners), one list per face in key order. Boundary landmarks of the outer
  loop are left out: they lie on the unit circle of the disk map, where the
  registration keeps the Möbius boundary correspondence.

The equivalent one-line conversion, for any other file holding one shared id
list under ``KEY``::

    python -c "import json,sys; d=json.load(open(sys.argv[1])); \
json.dump({'landmarks': [d['KEY']] * int(sys.argv[2])}, sys.stdout)" IN.json N > L.json

The JSON side (layouts, counts, entry checks) is :mod:`conformorph.pipelines.landmark_document`,
pure Python so that the API can check documents without numpy; its names are
re-exported here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.surface_distance import projected_barycentrics
from conformorph.pipelines.landmark_document import (
    SHARED_LIST_KEYS,
    DuplicateLandmarkError,
    LandmarkCountMismatchError,
    LandmarkError,
    LandmarkFormatError,
    LandmarkIndexError,
    LandmarkTooFarError,
    TooFewLandmarksError,
    check_landmark_entry,
    parse_landmark_json,
    read_landmark_file,
)

__all__ = [
    "MAX_SNAP_FRACTION",
    "SHARED_LIST_KEYS",
    "DuplicateLandmarkError",
    "LandmarkCountMismatchError",
    "LandmarkError",
    "LandmarkFormatError",
    "LandmarkIndexError",
    "LandmarkTooFarError",
    "SurfaceLandmarks",
    "TooFewLandmarksError",
    "parse_landmark_json",
    "read_landmark_file",
    "resolve_landmarks",
]

#: default: a point landmark farther from the surface than this fraction of the
#: bounding-box diagonal is rejected (a wrong file or wrong units, not a snap)
MAX_SNAP_FRACTION = 0.05


@dataclass(frozen=True)
class SurfaceLandmarks:
    """Landmarks of one mesh as surface points.

    Attributes
    ----------
    triangle : (m,) int64
        Triangle holding each landmark.
    barycentric : (m, 3) float64
        Barycentric coordinates in that triangle.
    points : (m, 3) float64
        3D positions on the surface.
    snap_distance : (m,) float64
        Distance from the given point to the surface (0 for vertex indices).
    vertex : (m,) int64
        The vertex index when the landmark was given as one, else -1.
    """

    triangle: NDArray[np.int64]
    barycentric: NDArray[np.float64]
    points: NDArray[np.float64]
    snap_distance: NDArray[np.float64]
    vertex: NDArray[np.int64]


def _who(mesh_index: int, i: int) -> str:
    """A landmark as a person reads it (1-based) with its 0-based JSON place, e.g.
    ``mesh 2, landmark 3 (landmarks[1][2])``."""
    return f"mesh {mesh_index + 1}, landmark {i + 1} (landmarks[{mesh_index}][{i}])"


def resolve_landmarks(
    entries: list[Any],
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    *,
    mesh_index: int = 0,
    max_snap_distance: float | None = None,
) -> SurfaceLandmarks:
    """Turn one mesh's entries (vertex ids or points) into surface landmarks.

    Parameters
    ----------
    entries : list
        Vertex indices (int) or ``[x, y, z]`` points.
    V : (n, 3) float64
    F : (k, 3) int64
    mesh_index : int
        For error messages.
    max_snap_distance : float, optional
        Default :data:`MAX_SNAP_FRACTION` × bounding-box diagonal.

    Returns
    -------
    SurfaceLandmarks

    Raises
    ------
    LandmarkIndexError, LandmarkTooFarError, DuplicateLandmarkError,
    TooFewLandmarksError, LandmarkFormatError
    """
    from conformorph.geometry.surface_distance import SurfaceDistance

    m = len(entries)
    if m < 3:
        raise TooFewLandmarksError(f"mesh {mesh_index}: at least 3 landmarks needed, got {m}")
    n = V.shape[0]
    diag = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    limit = MAX_SNAP_FRACTION * diag if max_snap_distance is None else float(max_snap_distance)
    vertex = np.full(m, -1, dtype=np.int64)
    pts = np.zeros((m, 3))
    is_pt = np.zeros(m, dtype=bool)
    for i, e in enumerate(entries):
        checked = check_landmark_entry(
            e, f"landmarks[{mesh_index}][{i}]", label=_who(mesh_index, i)
        )
        if isinstance(checked, int):
            if checked >= n:
                raise LandmarkIndexError(
                    f"{_who(mesh_index, i)}: vertex index {checked} is out of range 0..{n - 1}",
                    f"landmarks[{mesh_index}][{i}]",
                )
            vertex[i] = checked
        else:
            pts[i] = checked
            is_pt[i] = True
    dup = _first_duplicate(vertex[~is_pt])
    if dup is not None:
        raise DuplicateLandmarkError(f"mesh {mesh_index}: vertex {dup} is used by two landmarks")
    # each vertex landmark sits in one of its triangles with a one-hot barycentric
    tri = np.zeros(m, dtype=np.int64)
    bary = np.zeros((m, 3))
    snap = np.zeros(m)
    if (~is_pt).any():
        vi = vertex[~is_pt]
        t, col = _first_corner(F, vi)
        if (t < 0).any():
            bad = int(vi[t < 0][0])
            raise LandmarkIndexError(f"mesh {mesh_index}: vertex {bad} is in no triangle")
        tri[~is_pt] = t
        bary[np.flatnonzero(~is_pt), col] = 1.0
    if is_pt.any():
        sd = SurfaceDistance(V, F)
        closest, d, hit_tri = sd.closest_triangles(pts[is_pt], k=16)
        far = np.flatnonzero(d > limit)
        if far.size:
            i = int(np.flatnonzero(is_pt)[far[0]])
            raise LandmarkTooFarError(
                f"{_who(mesh_index, i)}: point is {float(d[far[0]]):.4g} from the surface "
                f"(limit {limit:.4g}, 5% of the bounding-box diagonal unless set); wrong units or mesh?"
            )
        # barycentrics of each closest point in the triangle that holds it
        tri[is_pt] = hit_tri
        bary[is_pt] = projected_barycentrics(closest, V[F[hit_tri]])
        snap[is_pt] = d
    points = np.einsum("mj,mjk->mk", bary, V[F[tri]])
    # pairs of equal surface points by a k-d tree: m log m, where a distance matrix
    # would hold m² distances (a document of many landmarks)
    from scipy.spatial import cKDTree

    same = cKDTree(points).query_pairs(1e-12 * max(diag, 1e-300), output_type="ndarray")
    if same.size:  # the first pair (i, j), j < i, in row order
        j, i = (int(x) for x in same[np.lexsort((same[:, 0], same[:, 1]))[0]])
        raise DuplicateLandmarkError(
            f"mesh {mesh_index + 1}: landmarks {j + 1} and {i + 1} are the same surface "
            f"point (landmarks[{mesh_index}][{j}] and [{i}])"
        )
    return SurfaceLandmarks(tri, bary, points, snap, vertex)


def _first_duplicate(a: NDArray[np.int64]) -> int | None:
    u, c = np.unique(a, return_counts=True)
    return int(u[c > 1][0]) if np.any(c > 1) else None


def _first_corner(
    F: NDArray[np.int64], vi: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """For each vertex of ``vi``: the first triangle (lowest index) that uses it and the
    corner it is there, or (-1, 0) for a vertex in no triangle. Linear in ``F``'s size.

    Parameters
    ----------
    F : (k, 3) int64
    vi : (q,) int64

    Returns
    -------
    tri : (q,) int64
    corner : (q,) int64
    """
    flat = F.ravel()
    at = np.flatnonzero(np.isin(flat, vi))  # every use of a landmark vertex, in order
    found, first = np.unique(flat[at], return_index=True)
    if found.size == 0:
        return np.full(vi.size, -1, dtype=np.int64), np.zeros(vi.size, dtype=np.int64)
    pos = np.searchsorted(found, vi)
    ok = pos < found.size
    ok[ok] = found[pos[ok]] == vi[ok]
    place = np.where(ok, at[first[np.minimum(pos, found.size - 1)]], -3)
    return place // 3, np.where(ok, place % 3, 0)
