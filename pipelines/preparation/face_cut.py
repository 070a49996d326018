"""The preparation's last resort: the face cut out of a surface that is still not a disk."""

from __future__ import annotations

from typing import Any

import numpy as np

from conformorph import geometry
from conformorph.geometry._typing import FloatArray, IntArray
from conformorph.geometry.mesh_errors import MeshError


def face_cut_reason(V: FloatArray, F: IntArray, min_roundness: float) -> str | None:
    """Why the face must be cut out of the mesh, or None when it is a face-like disk.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        Faces of a mesh without unreferenced vertices.
    min_roundness : float
        A single boundary loop of length L around area A with
        ``L² / (4π A)`` below this is the rim of a closed surface's opening (a
        head open at the neck: about 0.1), not a face's outline (0.63–1.36 on
        the shared faces; 0.5 for a hemisphere, 0.25 for a 120° spherical cap).

    Returns
    -------
    str or None
        ``"closed"``, ``"k boundary loops"``, ``"not a disk (…)"`` or
        ``"one boundary loop, isoperimetric quotient q < min_roundness"``.
    """
    E = geometry.mesh_edges(F)
    if E.boundary.size == 0:
        return "closed"
    if not is_disk_topology(F):
        try:
            return f"{len(geometry.boundary_loops(F, E))} boundary loops"
        except MeshError as exc:
            return f"not a disk ({exc})"
    loop = geometry.boundary_loops(F, E)[0]
    length = float(np.linalg.norm(V[loop] - V[np.roll(loop, -1)], axis=1).sum())
    q = length**2 / (4 * np.pi * float(geometry.triangle_areas(V, F).sum()))
    if q < min_roundness:
        return f"one boundary loop, isoperimetric quotient {q:.3g} < {min_roundness:g}"
    return None


def is_disk_topology(F: IntArray) -> bool:
    """Whether the faces form one piece with one boundary loop and Euler characteristic 1.

    Parameters
    ----------
    F : (m, 3) int64
        Faces of a mesh without unreferenced vertices.

    Returns
    -------
    bool
        False for a closed surface, several boundary loops, a handle, or
        loops that touch (a pinch).
    """
    E = geometry.mesh_edges(F)
    n = int(np.unique(F).size)
    if n - E.edges.shape[0] + F.shape[0] != 1:
        return False
    try:
        return len(geometry.boundary_loops(F, E)) == 1
    except MeshError:
        return False


def current_rows(src: IntArray, input_ids: IntArray) -> IntArray:
    """Rows (k,) of the current mesh holding the input vertices ``input_ids`` (absent ones dropped).

    ``src`` (n2,) is the input row of every current vertex (-1 for added ones);
    a split vertex counts by its first row.
    """
    first = np.full(int(max(src.max(initial=-1), input_ids.max(initial=-1))) + 1, -1, np.int64)
    rows = np.flatnonzero(src >= 0)[::-1]
    first[src[rows]] = rows  # written last to first: the first row wins
    found = first[input_ids]
    return found[found >= 0]


def cut_face(
    V: FloatArray,
    F: IntArray,
    src: IntArray,
    landmark_ids: Any,
    rep: dict[str, Any],
    reason: str = "not a disk",
) -> tuple[FloatArray, IntArray, IntArray]:
    """Cut the face out as a disk (:func:`conformorph.geometry.face_region`), then its ears.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        The mesh after the other preparation steps (not a disk).
    src : (n,) int64
        Input row of every vertex (-1 for added ones).
    landmark_ids : (k,) array_like of int or None
        Input vertex ids of the landmarks, if known: they place the face
        and all stay inside it.
    rep : dict
        The preparation report: ``rep["face_cut"]`` records why and what was
        cut (or ``{"reason", "problem"}`` when no disk could be cut out, the
        mesh then returned as it came).
    reason : str
        Why the cut runs (:func:`face_cut_reason`), recorded.

    Returns
    -------
    V2 : (n2, 3) float64
    F2 : (m2, 3) int64
    src2 : (n2,) int64
        Input row of every kept vertex.
    """
    rows = None
    if landmark_ids is not None:
        rows = current_rows(src, np.unique(np.asarray(landmark_ids, dtype=np.int64)))
    try:
        r = geometry.face_region(V, F, rows)
    except MeshError as exc:
        rep["face_cut"] = {"reason": reason, "problem": str(exc)}
        return V, F, src
    rep["face_cut"] = {
        "reason": reason,
        "from_landmarks": r.from_landmarks,
        "centre_vertex_id": int(src[r.centre]),
        "kept_vertices": int(r.vertex_map.size),
        "kept_faces": int(r.F.shape[0]),
        "removed_faces": int(F.shape[0] - r.F.shape[0]),
        "boundary_edges": r.boundary_edges,
        "boundary_crease_deg": round(r.boundary_crease_deg, 3),
        "filled_islands": r.filled_islands,
        "bowtie_fans": r.bowtie_fans,
    }
    V, F, src = V[r.vertex_map], r.F, src[r.vertex_map]
    V, F, kept = geometry.remove_boundary_ears(V, F)
    removed = np.setdiff1d(np.arange(src.size), kept)
    ears = sorted(int(i) for i in src[removed] if i >= 0)
    rep["face_cut"]["removed_ear_vertex_ids"] = ears
    return V, F, src[kept]
