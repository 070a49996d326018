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
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: default: a point landmark farther from the surface than this fraction of the
#: bounding-box diagonal is rejected (a wrong file or wrong units, not a snap)
MAX_SNAP_FRACTION = 0.05

#: keys of the shared-data files whose single id list applies to every mesh
SHARED_LIST_KEYS = ("landmarks_multipie68_0based", "nearest_vertex_0based")


class LandmarkError(ValueError):
    """Base class of landmark-file errors (a ValueError: the CLI maps it to exit code 2)."""

    code = "landmark_error"


class LandmarkCountMismatchError(LandmarkError):
    """The lists of landmarks differ in length, or their number differs from the meshes'."""

    code = "landmark_count_mismatch"


class LandmarkIndexError(LandmarkError):
    """A vertex index is out of range (or not an integer)."""

    code = "landmark_index_out_of_range"


class DuplicateLandmarkError(LandmarkError):
    """Two landmarks of one mesh are the same vertex or the same surface point."""

    code = "duplicate_landmarks"


class TooFewLandmarksError(LandmarkError):
    """Fewer than 3 landmarks per mesh."""

    code = "too_few_landmarks"


class LandmarkTooFarError(LandmarkError):
    """A point landmark is too far from the surface to be snapped."""

    code = "landmark_too_far"


class LandmarkFormatError(LandmarkError):
    """The file is not valid JSON or not in a recognised layout."""

    code = "landmark_format"


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


def parse_landmark_json(data: Any, n_meshes: int) -> list[list[Any]]:
    """Normalise the accepted JSON layouts to one list of entries per mesh.

    Parameters
    ----------
    data : object
        Parsed JSON.
    n_meshes : int
        Number of input meshes.

    Returns
    -------
    list of n_meshes lists

    Raises
    ------
    LandmarkFormatError, LandmarkCountMismatchError
    """
    if not isinstance(data, dict):
        raise LandmarkFormatError("landmark file must hold a JSON object")
    if "landmarks" in data:
        lists = data["landmarks"]
        if not isinstance(lists, list) or not all(isinstance(x, list) for x in lists):
            raise LandmarkFormatError('"landmarks" must be a list of lists, one per mesh')
    else:
        key = next((k for k in SHARED_LIST_KEYS if k in data), None)
        faces = sorted(
            (k for k in data if k.startswith("face") and isinstance(data[k], dict)),
            key=lambda k: (len(k), k),
        )
        if key is not None:
            if not isinstance(data[key], list):
                raise LandmarkFormatError(f'"{key}" must be a list of vertex ids')
            lists = [list(data[key]) for _ in range(n_meshes)]
        elif faces:
            lists = []
            for k in faces:
                d = data[k]
                try:
                    ids = list(d["interior_landmarks_0based"])
                    for loop in d.get("boundary_landmarks_0based_per_loop", [])[1:]:
                        ids += list(loop)
                except (KeyError, TypeError) as exc:
                    raise LandmarkFormatError(f'"{k}" lacks interior_landmarks_0based') from exc
                lists.append(ids)
        else:
            raise LandmarkFormatError(
                'no "landmarks" key (nor a known shared-data layout: '
                + ", ".join(SHARED_LIST_KEYS)
                + ", face1/face2/…)"
            )
    if len(lists) != n_meshes:
        raise LandmarkCountMismatchError(
            f"the landmark file has {len(lists)} lists but {n_meshes} meshes were given"
        )
    counts = [len(x) for x in lists]
    if len(set(counts)) != 1:
        raise LandmarkCountMismatchError(
            f"every mesh needs the same number of landmarks, got {counts} (mesh order)"
        )
    if counts[0] < 3:
        raise TooFewLandmarksError(f"at least 3 landmarks per mesh are needed, got {counts[0]}")
    return [list(x) for x in lists]


def read_landmark_file(path: str | Path, n_meshes: int) -> list[list[Any]]:
    """Read and parse a landmark file (see :func:`parse_landmark_json`)."""
    try:
        data = json.loads(Path(path).read_text())
    except json.JSONDecodeError as exc:
        raise LandmarkFormatError(f"{path}: not valid JSON: {exc}") from exc
    return parse_landmark_json(data, n_meshes)


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
    from geometry.surface_distance import SurfaceDistance

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
        if isinstance(e, bool):
            raise LandmarkFormatError(f"mesh {mesh_index}, landmark {i}: {e!r} is not an index")
        if isinstance(e, int) or (isinstance(e, float) and e.is_integer()):
            k = int(e)
            if not 0 <= k < n:
                raise LandmarkIndexError(
                    f"mesh {mesh_index}, landmark {i}: vertex index {k} is out of range 0..{n - 1}"
                )
            vertex[i] = k
        elif (
            isinstance(e, list)
            and len(e) == 3
            and all(isinstance(c, int | float) and not isinstance(c, bool) for c in e)
        ):
            pts[i] = np.asarray(e, dtype=np.float64)
            if not np.all(np.isfinite(pts[i])):
                raise LandmarkFormatError(f"mesh {mesh_index}, landmark {i}: non-finite point")
            is_pt[i] = True
        else:
            raise LandmarkFormatError(
                f"mesh {mesh_index}, landmark {i}: expected a vertex index or [x, y, z], got {e!r}"
            )
    dup = _first_duplicate(vertex[~is_pt])
    if dup is not None:
        raise DuplicateLandmarkError(f"mesh {mesh_index}: vertex {dup} is used by two landmarks")
    # each vertex landmark sits in one of its triangles with a one-hot barycentric
    tri = np.zeros(m, dtype=np.int64)
    bary = np.zeros((m, 3))
    snap = np.zeros(m)
    if (~is_pt).any():
        vi = vertex[~is_pt]
        hit = F[:, None, :] == vi[None, :, None]  # (k, q, 3) — small q
        anyhit = hit.any(axis=2)
        if not anyhit.any(axis=0).all():
            bad = int(vi[~anyhit.any(axis=0)][0])
            raise LandmarkIndexError(f"mesh {mesh_index}: vertex {bad} is in no triangle")
        t = np.argmax(anyhit, axis=0)
        tri[~is_pt] = t
        col = np.argmax(hit[t, np.arange(vi.size)], axis=1)
        bary[np.flatnonzero(~is_pt), col] = 1.0
    if is_pt.any():
        sd = SurfaceDistance(V, F)
        closest, d = sd.closest_points(pts[is_pt], k=16)
        far = np.flatnonzero(d > limit)
        if far.size:
            i = int(np.flatnonzero(is_pt)[far[0]])
            raise LandmarkTooFarError(
                f"mesh {mesh_index}, landmark {i}: point is {float(d[far[0]]):.4g} from the surface "
                f"(limit {limit:.4g}, 5% of the bounding-box diagonal unless set); wrong units or mesh?"
            )
        for j, i in enumerate(np.flatnonzero(is_pt).tolist()):
            # barycentrics of the closest point in its triangle (nearest of candidate triangles)
            t, w = _triangle_of_point(V, F, closest[j])
            tri[i], bary[i], snap[i] = t, w, d[j]
    points = np.einsum("mj,mjk->mk", bary, V[F[tri]])
    for i in range(m):
        for j in range(i):
            if np.linalg.norm(points[i] - points[j]) <= 1e-12 * max(diag, 1e-300):
                raise DuplicateLandmarkError(
                    f"mesh {mesh_index}: landmarks {j} and {i} are the same surface point"
                )
    return SurfaceLandmarks(tri, bary, points, snap, vertex)


def _first_duplicate(a: NDArray[np.int64]) -> int | None:
    u, c = np.unique(a, return_counts=True)
    return int(u[c > 1][0]) if np.any(c > 1) else None


def _triangle_of_point(
    V: NDArray[np.float64], F: NDArray[np.int64], p: NDArray[np.float64]
) -> tuple[int, NDArray[np.float64]]:
    """Triangle and barycentrics of a point lying on the surface (nearest by plane distance)."""
    c = V[F]  # (k, 3, 3)
    e0 = c[:, 1] - c[:, 0]
    e1 = c[:, 2] - c[:, 0]
    d = p - c[:, 0]
    d00 = np.einsum("ij,ij->i", e0, e0)
    d01 = np.einsum("ij,ij->i", e0, e1)
    d11 = np.einsum("ij,ij->i", e1, e1)
    d20 = np.einsum("ij,ij->i", d, e0)
    d21 = np.einsum("ij,ij->i", d, e1)
    den = d00 * d11 - d01 * d01
    den = np.where(den != 0, den, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    lam = np.stack([1 - v - w, v, w], axis=1)
    lam_c = np.clip(lam, 0.0, None)
    lam_c /= np.maximum(lam_c.sum(axis=1, keepdims=True), 1e-300)
    q = np.einsum("kj,kjd->kd", lam_c, c)
    t = int(np.argmin(np.linalg.norm(q - p, axis=1)))
    return t, lam_c[t]
