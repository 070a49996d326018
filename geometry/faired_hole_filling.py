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


def _strip_faces(outer: IntArray, inner: IntArray) -> IntArray:
    """Triangles of the strip between two closed rings of any sizes (a "zipper")."""
    a, b = outer.size, inner.size
    faces = []
    i = j = 0
    while i < a or j < b:
        # advance along the ring whose next vertex comes first (by fraction of its length)
        if j == b or (i < a and (i + 1) * b <= (j + 1) * a):
            faces.append((outer[(i + 1) % a], outer[i % a], inner[j % b]))
            i += 1
        else:
            faces.append((outer[i % a], inner[j % b], inner[(j + 1) % b]))
            j += 1
    return np.asarray(faces, dtype=np.int64)


def hole_patch_faces(loop: IntArray, first: int, ring_sizes: list[int]) -> tuple[IntArray, int]:
    """Triangles of a patch of concentric rings plus a centre inside ``loop``.

    Parameters
    ----------
    loop : (k,) int64
        The hole's boundary loop, oriented with the mesh on its left (as
        :func:`geometry.boundary_loops` returns it), k ≥ 3.
    first : int
        Index of the first new vertex; the rings' vertices follow in order,
        outermost first, then the centre.
    ring_sizes : list of int
        Vertex count of each ring of new vertices, outermost first (each ≥ 3).

    Returns
    -------
    faces : (k + 2 Σ ring_sizes, 3) int64
        Strips between successive rings and a fan to the centre, oriented to
        continue the mesh's orientation.
    added : int
        New vertices: ``Σ ring_sizes + 1``.

    Raises
    ------
    ValueError
        A loop shorter than 3 or a ring smaller than 3.

    Examples
    --------
    >>> hole_patch_faces(np.array([0, 1, 2]), 3, [])[0].tolist()
    [[1, 0, 3], [2, 1, 3], [0, 2, 3]]
    """
    loop = np.asarray(loop, dtype=np.int64)
    if loop.ndim != 1 or loop.size < 3:
        raise ValueError(f"a hole loop needs at least 3 vertices, got {loop.shape}")
    if any(int(r) < 3 for r in ring_sizes):
        raise ValueError(f"every ring needs at least 3 vertices, got {list(ring_sizes)}")
    faces = []
    outer = loop
    nxt = first
    for size in ring_sizes:
        inner = nxt + np.arange(int(size), dtype=np.int64)
        faces.append(_strip_faces(outer, inner))
        outer = inner
        nxt += int(size)
    faces.append(np.stack([np.roll(outer, -1), outer, np.full(outer.size, nxt)], axis=1))
    return np.vstack(faces), nxt + 1 - first


def patch_rings(k: int) -> list[int]:
    """Ring sizes for a hole of ``k`` loop vertices: triangles about as long as the loop's edges.

    A loop of ``k`` edges of length ``h`` encloses a radius of about
    ``k h / 2π``, so ``R = round(k / 2π) - 1`` rings at spacing about ``h``,
    ring ``r`` (outermost 1) with ``k (R + 1 - r) / (R + 1)`` vertices (at
    least 3): edges along each ring stay about ``h`` long.

    Examples
    --------
    >>> patch_rings(6), patch_rings(32)
    ([], [26, 19, 13, 6])
    """
    R = max(0, round(k / (2 * np.pi)) - 1)
    return [max(3, round(k * (R + 1 - r) / (R + 1))) for r in range(1, R + 1)]


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
    Each patch is a stack of concentric rings, smaller towards the middle,
    closed by a fan to a centre (:func:`hole_patch_faces`,
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
        faces, added = hole_patch_faces(lp, nxt, patch_rings(int(lp.size)))
        new_faces.append(faces)
        nxt += added
        filled.append(int(lp.size))
    F2 = np.vstack(new_faces)
    V2 = np.vstack([V, np.zeros((nxt - V.shape[0], 3))])
    if nxt > V.shape[0]:
        V2 = biharmonic_fill(F2, V2, np.arange(V.shape[0], nxt))
    return FilledHoles(V2, F2, filled, unfilled)
