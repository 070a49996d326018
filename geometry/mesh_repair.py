"""Repairs offered by validation: remove boundary ears, fill holes."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .boundary_loop import boundary_loops
from .validate_mesh import boundary_ear_vertices


def remove_boundary_ears(V: FloatArray, F: IntArray) -> tuple[FloatArray, IntArray, IntArray]:
    """Remove boundary vertices that lie in a single triangle, repeatedly.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Returns
    -------
    V2 : (n2, 3) float64
        Kept vertices, in their original relative order.
    F2 : (m2, 3) int64
        Kept triangles, re-indexed.
    kept : (n2,) int64
        ``kept[i]`` is the input index of output vertex ``i`` (so landmark
        indices can be translated with ``np.searchsorted(kept, idx)``).

    Notes
    -----
    Removing an ear can make its neighbour an ear, so this repeats until none
    is left; it stops if a removal would delete every face.
    """
    F2 = np.asarray(F, dtype=np.int64)
    while True:
        ears = boundary_ear_vertices(F2)
        if ears.size == 0:
            break
        drop = np.isin(F2, ears).any(axis=1)
        if drop.all():
            break
        F2 = F2[~drop]
    kept = np.unique(F2)
    remap = np.full(V.shape[0], -1, dtype=np.int64)
    remap[kept] = np.arange(kept.size)
    return np.asarray(V, dtype=np.float64)[kept].copy(), remap[F2], kept


def fill_holes(V: FloatArray, F: IntArray) -> tuple[FloatArray, IntArray]:
    """Close every boundary loop but the longest with a fan to its centroid.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Returns
    -------
    V2 : (n + h, 3) float64
        The input vertices, unchanged and in order, then one new vertex per
        hole (the centroid of its loop).
    F2 : (m + Σ k_i, 3) int64
        The input triangles, then the fans, oriented consistently.

    Notes
    -----
    A fan is a topological fix for hole-like openings (eyes, mouth) before a
    disk map; it leaves poorly shaped triangles for long non-convex holes,
    which the conformal map tolerates but whose distortion then shows in the
    quality measures. The input vertex ids are kept, so landmarks still apply.
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    loops = boundary_loops(F)
    if len(loops) <= 1:
        return V.copy(), F.copy()
    # the outer loop is the longest in 3D
    lengths = [float(np.linalg.norm(V[lp] - V[np.roll(lp, -1)], axis=1).sum()) for lp in loops]
    outer = int(np.argmax(lengths))
    newV = [V]
    newF = [F]
    nxt = V.shape[0]
    for i, lp in enumerate(loops):
        if i == outer:
            continue
        newV.append(V[lp].mean(axis=0, keepdims=True))
        # the loop runs with the mesh on its left: the fan triangle (j+1, j, c) continues the orientation
        newF.append(np.stack([np.roll(lp, -1), lp, np.full(lp.size, nxt)], axis=1))
        nxt += 1
    return np.vstack(newV), np.vstack(newF)
