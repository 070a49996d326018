"""Fill the holes of a disk-like mesh with patches that follow the surface's curvature:
concentric rings of new vertices, placed by the bi-Laplacian (:func:`biharmonic_fill`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .biharmonic_fill import biharmonic_fill
from .boundary_loop import boundary_loops
from .mesh_edges import mesh_edges


@dataclass(frozen=True)
class FilledHoles:
    """What :func:`fill_holes_faired` filled.

    Attributes
    ----------
    V : (n + a, 3) float64
        The input vertices, unchanged and in order, then the ``a`` patch vertices.
    F : (m + b, 3) int64
        The input faces, then the patches' ``b`` faces (oriented like the mesh).
    filled_loop_sizes : list of int
        Vertex count of every filled hole's loop.
    unfilled_loop_sizes : list of int
        Loops left open besides the outer one (longer than the size limit).
    """

    V: FloatArray
    F: IntArray
    filled_loop_sizes: list[int]
    unfilled_loop_sizes: list[int]


def hole_patch_faces(loop: IntArray, first: int, rings: int) -> tuple[IntArray, int]:
    """Triangles of a patch of ``rings`` concentric rings plus a centre inside ``loop``.

    Parameters
    ----------
    loop : (k,) int64
        The hole's boundary loop, oriented with the mesh on its left (as
        :func:`geometry.boundary_loops` returns it), k ≥ 3.
    first : int
        Index of the first new vertex; ring ``r`` (1-based) is ``first + (r-1) k
        .. first + r k - 1`` and the centre is ``first + rings k``.
    rings : int
        Rings of ``k`` new vertices between the loop and the centre (≥ 0).

    Returns
    -------
    faces : ((2 rings + 1) k, 3) int64
        Quad strips between successive rings (two triangles each) and a fan
        to the centre, oriented to continue the mesh's orientation.
    added : int
        New vertices: ``rings k + 1``.

    Examples
    --------
    >>> hole_patch_faces(np.array([0, 1, 2]), 3, 0)[0].tolist()
    [[1, 0, 3], [2, 1, 3], [0, 2, 3]]
    """
    loop = np.asarray(loop, dtype=np.int64)
    k = loop.size
    if loop.ndim != 1 or k < 3:
        raise ValueError(f"a hole loop needs at least 3 vertices, got {loop.shape}")
    if rings < 0:
        raise ValueError(f"rings must be >= 0, got {rings}")
    faces = []
    outer = loop
    for r in range(rings):
        inner = first + r * k + np.arange(k, dtype=np.int64)
        o1, i1 = np.roll(outer, -1), np.roll(inner, -1)
        # quad (o[j+1], o[j], i[j], i[j+1]) split along o[j+1]-i[j]
        faces.append(np.stack([o1, outer, inner], axis=1))
        faces.append(np.stack([o1, inner, i1], axis=1))
        outer = inner
    centre = first + rings * k
    faces.append(np.stack([np.roll(outer, -1), outer, np.full(k, centre)], axis=1))
    return np.vstack(faces), rings * k + 1


def patch_rings(V: FloatArray, loop: IntArray) -> int:
    """Rings for a hole so the patch's triangles are about as long as the loop's edges.

    A loop of perimeter ``P`` encloses a radius of about ``P / 2π``; with
    edges of mean length ``h`` that is ``k / 2π`` edge lengths, so
    ``round(k / 2π) - 1`` rings (at least 0) and the centre.
    """
    del V  # the count depends on the loop's vertex count only
    return max(0, round(loop.size / (2 * np.pi)) - 1)


def fill_holes_faired(V: FloatArray, F: IntArray, *, max_hole_fraction: float = 0.5) -> FilledHoles:
    """Fill every inner boundary loop up to a size with a faired patch.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        An oriented, edge- and vertex-manifold mesh without unreferenced
        vertices, with at least one boundary loop.
    max_hole_fraction : float
        A loop is filled when its length is at most this fraction of the
        outer loop's (the longest in 3D). Default 0.5: eyes, mouths and scan
        holes, not a second outer boundary of similar size.

    Returns
    -------
    FilledHoles

    Raises
    ------
    ValueError
        ``max_hole_fraction`` not in (0, 1], or the mesh has no boundary.
    NonManifoldError
        From :func:`geometry.boundary_loops` when loops touch at a vertex.

    Notes
    -----
    Each patch is a stack of concentric rings of ``k`` vertices (``k`` the
    loop's size) closed by a fan to a centre (:func:`hole_patch_faces`,
    :func:`patch_rings`). Its vertices are then solved together by the
    bi-Laplacian with every other vertex fixed (:func:`biharmonic_fill`), so
    the patch continues the surface's position and slope across the loop
    instead of the flat fan of :func:`geometry.fill_holes`.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if not 0.0 < max_hole_fraction <= 1.0:
        raise ValueError(f"max_hole_fraction must be in (0, 1], got {max_hole_fraction}")
    loops = boundary_loops(F, mesh_edges(F))
    if not loops:
        raise ValueError("the mesh has no boundary (a closed surface): no hole to fill")
    lengths = [float(np.linalg.norm(V[lp] - V[np.roll(lp, -1)], axis=1).sum()) for lp in loops]
    outer = int(np.argmax(lengths))
    new_faces = [F]
    nxt = V.shape[0]
    filled, unfilled = [], []
    for i, lp in enumerate(loops):
        if i == outer:
            continue
        if lengths[i] > max_hole_fraction * lengths[outer]:
            unfilled.append(int(lp.size))
            continue
        faces, added = hole_patch_faces(lp, nxt, patch_rings(V, lp))
        new_faces.append(faces)
        nxt += added
        filled.append(int(lp.size))
    F2 = np.vstack(new_faces)
    V2 = np.vstack([V, np.zeros((nxt - V.shape[0], 3))])
    if nxt > V.shape[0]:
        V2 = biharmonic_fill(F2, V2, np.arange(V.shape[0], nxt))
    return FilledHoles(V2, F2, filled, unfilled)
