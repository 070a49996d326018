"""Make a triangle mesh manifold: drop the extra faces of non-manifold edges, split pinched
vertices."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ._face_array import faces_and_vertex_count
from ._typing import IntArray


@dataclass(frozen=True)
class ManifoldSplit:
    """A manifold version of a triangle mesh.

    Attributes
    ----------
    F : (m2, 3) int64
        The kept faces, in input order, with split vertices re-indexed.
    face_kept : (m,) bool
        Which input faces are kept.
    source : (n2,) int64
        Input vertex of every output vertex: ``arange(n)`` followed by the
        vertex each appended copy was split from.
    dropped_faces : int
        Faces dropped from edges used by more than two faces.
    split_vertices : int
        Input vertices split into several (one per edge-connected fan).
    """

    F: IntArray
    face_kept: np.ndarray
    source: IntArray
    dropped_faces: int
    split_vertices: int


def _overused_edge_faces(F: IntArray, n: int) -> np.ndarray:
    """(m,) bool: faces kept when every edge keeps only its first two faces (in face order)."""
    he = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)  # half-edge 3 f + k
    key = np.sort(he, axis=1) @ np.array([n, 1], dtype=np.int64)
    order = np.argsort(key, kind="stable")
    k = key[order]
    start = np.r_[0, np.flatnonzero(np.diff(k)) + 1]
    rank = np.arange(k.size) - np.repeat(start, np.diff(np.r_[start, k.size]))
    extra = np.zeros(he.shape[0], dtype=bool)
    extra[order[rank >= 2]] = True
    return np.logical_not(extra.reshape(-1, 3).any(axis=1))


def _corner_fans(F: IntArray, n: int) -> IntArray:
    """(3 m,) fan label of every corner ``3 f + k``: corners at one vertex joined by a shared
    edge through it are in the same fan."""
    m = F.shape[0]
    corner_vertex = F.reshape(-1)
    nxt = np.roll(F, -1, axis=1).reshape(-1)
    prv = np.roll(F, 1, axis=1).reshape(-1)
    corners = np.arange(3 * m)
    # each corner touches the directed edges (v -> next) and (v -> prev) at its vertex
    keys = np.concatenate([corner_vertex * n + nxt, corner_vertex * n + prv])
    owner = np.concatenate([corners, corners])
    order = np.argsort(keys, kind="stable")
    ks = keys[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    u, v = owner[order[same]], owner[order[same + 1]]
    G = sp.coo_array((np.ones(u.size), (u, v)), shape=(3 * m, 3 * m))
    _, labels = connected_components(G, directed=False)
    return labels.astype(np.int64)


def split_nonmanifold(F: IntArray, n: int | None = None) -> ManifoldSplit:
    """Drop the faces beyond two on every edge, then split every vertex with several fans.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles without repeated indices within a face.
    n : int, optional
        Vertex count (default ``F.max() + 1``).

    Returns
    -------
    ManifoldSplit
        Every edge of ``F`` used by at most two faces and every vertex's faces
        one edge-connected fan. The largest fan of a split vertex (by corner
        count, the first among equals) keeps its index; the others get
        copies appended after the ``n`` input vertices.

    Raises
    ------
    ValueError
        ``F`` is not an (m, 3) array of indices in ``0..n-1``, or repeats a
        vertex within a face.

    Notes
    -----
    An edge shared by three or more faces (a fin, a doubled sheet) keeps the
    two faces that come first in face order. A vertex where two surface
    pieces touch (a bow tie) becomes one vertex per piece, so the pieces may
    become separate components, which :func:`conformorph.geometry.largest_component`
    then tells apart.

    Examples
    --------
    Two triangles touching at vertex 0 (a bow tie):

    >>> s = split_nonmanifold(np.array([[0, 1, 2], [0, 3, 4]]))
    >>> s.F.tolist(), s.source.tolist()
    ([[0, 1, 2], [5, 3, 4]], [0, 1, 2, 3, 4, 0])
    """
    F, n = faces_and_vertex_count(F, n)
    if np.any((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])):
        raise ValueError("F repeats a vertex within a face; drop degenerate faces first")
    keep = _overused_edge_faces(F, n)
    G = F[keep]
    labels = _corner_fans(G, n)
    cv = G.reshape(-1)
    fan_size = np.bincount(labels)
    # per vertex, the fans at it ordered by size (largest first) then label
    order = np.lexsort((labels, -fan_size[labels], cv))
    cv_s, lab_s = cv[order], labels[order]
    new_fan = np.r_[True, (cv_s[1:] != cv_s[:-1]) | (lab_s[1:] != lab_s[:-1])]
    new_vertex = np.r_[True, cv_s[1:] != cv_s[:-1]]
    fan_starts = np.flatnonzero(new_fan)
    extra = fan_starts[~new_vertex[fan_starts]]  # second, third … fans of a vertex
    fan_index = np.full(labels.max() + 1, -1, dtype=np.int64)
    fan_index[lab_s[extra]] = n + np.arange(extra.size)
    target = np.where(fan_index[labels] >= 0, fan_index[labels], cv)
    return ManifoldSplit(
        F=target.reshape(-1, 3),
        face_kept=keep,
        source=np.concatenate([np.arange(n, dtype=np.int64), cv_s[extra]]),
        dropped_faces=int((~keep).sum()),
        split_vertices=int(np.unique(cv_s[extra]).size),
    )
