"""Repairs offered by validation: remove boundary ears, fill holes."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .boundary_loop import boundary_loops
from .validate_mesh import boundary_ear_vertices, validate_mesh_elements


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

    Raises
    ------
    MeshError
        From :func:`geometry.validate_mesh_elements`, which runs first: an
        out-of-range face index raises
        :class:`~geometry.FaceIndexOutOfRangeError`, an unreferenced vertex
        is an error rather than silently dropped.

    Notes
    -----
    Removing an ear can make its neighbour an ear, so this repeats until none
    is left; it stops if a removal would delete every face.
    :func:`extend_uv_to_ears` gives a map of the repaired mesh back its
    removed vertices.
    """
    V, F2 = validate_mesh_elements(V, F)
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
    return V[kept], remap[F2], kept


def extend_uv_to_ears(uv: FloatArray, F: IntArray, kept: IntArray) -> FloatArray:
    """Give a disk map of an ear-removed mesh back the removed ear vertices.

    Every removed vertex lay in a single triangle ``(p, e, q)`` when it was
    removed, with ``p`` and ``q`` on the boundary of what remained. Re-adding
    the ears in reverse order of removal, each ``e`` goes on the unit circle
    at the middle of the arc between ``p`` and ``q`` on the side away from
    the mesh (the side that orients its triangle like the rest of the map).
    The result is a disk map of the whole input mesh: boundary on the unit
    circle, no triangle flipped, the map itself unchanged on the kept
    vertices; the ear triangles are as distorted as ears always are.

    Parameters
    ----------
    uv : (n2, 2) float64
        Disk map of the repaired mesh (boundary on the unit circle), rows in
        the order of ``kept``.
    F : (m, 3) int64
        Triangles of the input mesh, before :func:`remove_boundary_ears`.
    kept : (n2,) int64
        Input indices of the kept vertices, as returned by
        :func:`remove_boundary_ears` (increasing).

    Returns
    -------
    uv_all : (n, 2) float64
        One row per input vertex (``n = F.max() + 1``); ``uv_all[kept] == uv``.

    Raises
    ------
    ValueError
        Shapes disagree, or ``kept`` is not what :func:`remove_boundary_ears`
        returns for ``F`` (a removed vertex cannot be placed).

    Examples
    --------
    A square of two triangles with an ear ``4`` on its edge ``(1, 2)``:

    >>> F = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    >>> uv = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])
    >>> np.round(extend_uv_to_ears(uv, F, np.array([0, 1, 2, 3]))[4], 6)
    array([-0.707107,  0.707107])
    """
    uv = np.asarray(uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    kept = np.asarray(kept, dtype=np.int64)
    if F.ndim != 2 or F.shape[1] != 3 or F.size == 0 or F.min() < 0:
        raise ValueError(f"F must be a non-empty (m, 3) array of vertex indices, got {F.shape}")
    n = int(F.max()) + 1
    if kept.ndim != 1 or uv.shape != (kept.size, 2):
        raise ValueError(f"uv must have one row per kept vertex: uv {uv.shape}, kept {kept.shape}")
    if kept.size and (kept.min() < 0 or kept.max() >= n or np.any(np.diff(kept) <= 0)):
        raise ValueError(f"kept must be increasing vertex indices in 0..{n - 1}")
    out = np.full((n, 2), np.nan)
    out[kept] = uv
    placed = np.zeros(n, dtype=bool)
    placed[kept] = True
    kept_faces = placed[F].all(axis=1)
    z = uv[:, 0] + 1j * uv[:, 1]
    Fk = np.searchsorted(kept, F[kept_faces])
    a = z[Fk]
    area = ((a[:, 1] - a[:, 0]).conjugate() * (a[:, 2] - a[:, 0])).imag.sum()
    sign = 1.0 if area >= 0 else -1.0  # the map's orientation
    todo = F[~kept_faces]
    # A removed face has its ear among its unplaced corners; it is ready to
    # place once the ear is the only one (the ears of later rounds are placed
    # by then). Each round places a whole generation of ears.
    while todo.size:
        unplaced = ~placed[todo]
        ready = unplaced.sum(axis=1) == 1
        if not ready.any():
            raise ValueError(
                f"{int((~placed).sum())} removed vertices cannot be placed: kept is not "
                "what remove_boundary_ears returns for these faces"
            )
        T = todo[ready]
        k = np.argmax(unplaced[ready], axis=1)  # the ear's corner
        e = T[np.arange(T.shape[0]), k]
        p = T[np.arange(T.shape[0]), (k + 2) % 3]  # the corners before and after e
        q = T[np.arange(T.shape[0]), (k + 1) % 3]
        zp = out[p, 0] + 1j * out[p, 1]
        zq = out[q, 0] + 1j * out[q, 1]
        mid = np.exp(1j * (np.angle(zp) + 0.5 * np.angle(zq / zp)))  # minor-arc middle
        # triangle (p, e, q) keeps the map's orientation if e is on the far side
        # of the chord pq from the mesh: flip the midpoint to the major arc if not
        turn = ((mid - zp).conjugate() * (zq - zp)).imag  # orientation of (p, mid, q)
        mid = np.where(turn * sign > 0, mid, -mid)
        out[e] = np.column_stack([mid.real, mid.imag])
        placed[e] = True
        todo = todo[~ready]
    return out


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

    Raises
    ------
    MeshError
        From :func:`geometry.validate_mesh_elements`, which runs first.

    Notes
    -----
    A fan is a topological fix for hole-like openings (eyes, mouth) before a
    disk map; it leaves poorly shaped triangles for long non-convex holes,
    which the conformal map tolerates but whose distortion then shows in the
    quality measures. The input vertex ids are kept, so landmarks still apply.
    """
    V, F = validate_mesh_elements(V, F)
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
