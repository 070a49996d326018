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
        Boundary loops of total length L around area A with ``L² / (4π A)``
        below this are the rims of a closed surface's openings (a head open at
        the neck: about 0.03), not a face's outline (0.63–1.36 on the shared
        faces; 0.5 for a hemisphere, 0.25 for a 120° spherical cap).

    Returns
    -------
    str or None
        ``"closed"``; ``"k boundary loops short for the area (quotient q <
        min_roundness)"`` (the cut fills them first: :func:`close_loops`);
        ``"k boundary loops"`` or ``"not a disk (…)"`` for other non-disks;
        None for a disk whose loop is long enough to be a face's outline.
    """
    E = geometry.mesh_edges(F)
    if E.boundary.size == 0:
        return "closed"
    try:
        loops = geometry.boundary_loops(F, E)
    except MeshError as exc:
        return f"not a disk ({exc})"
    length = sum(float(np.linalg.norm(V[lp] - V[np.roll(lp, -1)], axis=1).sum()) for lp in loops)
    q = length**2 / (4 * np.pi * float(geometry.triangle_areas(V, F).sum()))
    if q < min_roundness:
        return (
            f"{len(loops)} boundary loops short for the area (quotient {q:.3g} < {min_roundness:g})"
        )
    if not is_disk_topology(F):
        return f"{len(loops)} boundary loops"
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
    """Rows of the current mesh that hold the input vertices ``input_ids``.

    Parameters
    ----------
    src : (n2,) int64
        Input row of every current vertex (-1 for added ones).
    input_ids : (k,) int64
        Input vertex ids (≥ 0).

    Returns
    -------
    (k2,) int64
        The first row of each id present (a split vertex counts by its first
        row), in the order of ``input_ids``; ids no row holds are dropped.
    """
    size = int(max(src.max(initial=-1), input_ids.max(initial=-1))) + 1
    first = np.full(size, src.size, dtype=np.int64)
    rows = np.flatnonzero(src >= 0)
    np.minimum.at(first, src[rows], rows)  # the first row of each input vertex
    found = first[input_ids]
    found[found == src.size] = -1
    return found[found >= 0]


def close_loops(
    V: FloatArray, F: IntArray, src: IntArray
) -> tuple[FloatArray, IntArray, IntArray, list[int]]:
    """Fill every boundary loop with a faired patch: a closed surface comes out.

    For a surface whose loops are short for its area (a head open at the neck,
    a closed head with holes the hole filling left because one of them is the
    longest): the face cut then sees the surface whole, holes in the face
    included, rather than carving around them.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        A mesh with boundary loops that do not touch.
    src : (n,) int64
        Input row of every vertex (-1 for added ones).

    Returns
    -------
    V2 : (n2, 3) float64
        ``V`` and the patch's vertices after them (placed by
        :func:`conformorph.geometry.biharmonic_fill`).
    F2 : (m2, 3) int64
    src2 : (n2,) int64
        ``src`` and -1 for each added vertex.
    loop_sizes : list of int
        Vertices on each loop filled.
    """
    new, nxt, sizes = [F], V.shape[0], []
    for loop in geometry.boundary_loops(F):
        faces, added = geometry.hole_patch_faces(loop, nxt, geometry.patch_rings(loop.size))
        new.append(faces)
        nxt += added
        sizes.append(int(loop.size))
    F2 = np.vstack(new)
    V2 = np.vstack([V, np.zeros((nxt - V.shape[0], 3))])
    V2 = geometry.biharmonic_fill(F2, V2, np.arange(V.shape[0], nxt))
    return V2, F2, np.concatenate([src, np.full(nxt - src.size, -1, dtype=np.int64)]), sizes


def cut_face(
    V: FloatArray,
    F: IntArray,
    src: IntArray,
    landmark_ids: Any,
    rep: dict[str, Any],
    reason: str = "not a disk",
) -> tuple[FloatArray, IntArray, IntArray]:
    """Cut the face out as a disk (:func:`conformorph.geometry.face_region`), then its ears.

    The region is what a frontal scanner would see of the head: it follows a
    crease where the face meets the rest (a face glued onto a head) and, where
    none does (a real scan), reaches out from the landmarks' hull toward the
    hairline rather than taking the shortest loop around the hull, which cuts
    the forehead and cheeks away (see :func:`~conformorph.geometry.face_region`'s
    notes).

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
        cut (``kept_*`` and ``removed_faces`` count the output, after its ears
        are taken off), or ``{"reason", "problem"}`` when no disk could be cut
        out, the mesh then returned as it came.
    reason : str
        Why the cut runs (:func:`face_cut_reason`), recorded. Loops short
        for the area are first filled (:func:`close_loops`; ``closed_loops``
        their vertex counts).

    Returns
    -------
    V2 : (n2, 3) float64
    F2 : (m2, 3) int64
    src2 : (n2,) int64
        Input row of every kept vertex.
    """
    closed: list[int] = []
    V0, F0, src0 = V, F, src
    if "short for the area" in reason:
        V, F, src, closed = close_loops(V, F, src)
    rows = None
    if landmark_ids is not None:
        rows = current_rows(src, np.unique(np.asarray(landmark_ids, dtype=np.int64)))
    try:
        r = geometry.face_region(V, F, rows)
    except MeshError as exc:
        rep["face_cut"] = {"reason": reason, "problem": str(exc)}
        return V0, F0, src0
    centre = int(src[r.centre])
    faces_in = F.shape[0]  # the loops' patches included
    V, F, src = V[r.vertex_map], r.F, src[r.vertex_map]
    V, F, kept = geometry.remove_boundary_ears(V, F)
    removed = np.setdiff1d(np.arange(src.size), kept)
    rep["face_cut"] = {  # kept and removed: what the output holds, ears taken off
        "reason": reason,
        "closed_loops": closed,
        "from_landmarks": r.from_landmarks,
        "centre_vertex_id": centre,
        "kept_vertices": int(kept.size),
        "kept_faces": int(F.shape[0]),
        "removed_faces": int(faces_in - F.shape[0]),
        "boundary_edges": r.boundary_edges,
        "boundary_crease_deg": round(r.boundary_crease_deg, 3),
        "filled_islands": r.filled_islands,
        "bowtie_fans": r.bowtie_fans,
        "removed_ear_vertex_ids": sorted(int(i) for i in src[removed] if i >= 0),
    }
    return V, F, src[kept]
