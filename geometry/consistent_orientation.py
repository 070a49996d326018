"""Consistent face orientation of an edge-manifold triangle mesh (each component as most of
its faces already are)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components

from ._face_array import faces_and_vertex_count
from ._typing import IntArray


@dataclass(frozen=True)
class OrientedFaces:
    """Faces reoriented to agree across every interior edge.

    Attributes
    ----------
    F : (m, 3) int64
        The faces, in input order; a flipped face keeps its first corner and
        swaps the other two.
    flipped : (m,) bool
        Which faces were flipped.
    inconsistent_edges : int
        Interior edges still used in the same direction by both faces
        afterwards (> 0 only for a non-orientable surface, e.g. a Möbius strip).
    """

    F: IntArray
    flipped: np.ndarray
    inconsistent_edges: int


def _interior_pairs(F: IntArray, n: int) -> tuple[IntArray, IntArray, np.ndarray]:
    """(f1, f2, same): the two faces of every interior edge and whether they run it the
    same way (an orientation conflict)."""
    he = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.sort(he, axis=1) @ np.array([n, 1], dtype=np.int64)
    order = np.argsort(key, kind="stable")
    k = key[order]
    pair = np.flatnonzero(k[1:] == k[:-1])
    h1, h2 = order[pair], order[pair + 1]
    return h1 // 3, h2 // 3, he[h1, 0] == he[h2, 0]


def consistent_orientation(F: IntArray, n: int | None = None) -> OrientedFaces:
    """Flip faces so that every interior edge is used in opposite directions by its faces.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles of an edge-manifold mesh (no edge in more than two faces;
        :func:`geometry.split_nonmanifold` makes one).
    n : int, optional
        Vertex count (default ``F.max() + 1``).

    Returns
    -------
    OrientedFaces
        In each edge-connected component the orientation held by more faces
        is kept (the first face's among equals), so a consistently oriented
        mesh comes back unchanged.

    Raises
    ------
    ValueError
        ``F`` is not a non-empty (m, 3) array of indices in ``0..n-1``, or an
        edge is used by more than two faces.

    Notes
    -----
    A breadth-first tree over the face adjacency (one virtual root joined to
    every component) gives each face the parity of the flips on its path to
    the root, summed by pointer jumping (``O(m log depth)``, vectorised).

    Examples
    --------
    >>> consistent_orientation(np.array([[0, 1, 2], [1, 2, 3], [0, 2, 4]])).F.tolist()
    [[0, 1, 2], [1, 3, 2], [0, 2, 4]]
    """
    F, n = faces_and_vertex_count(F, n)
    m = F.shape[0]
    und = np.sort(np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    if np.unique(und @ np.array([n, 1], dtype=np.int64), return_counts=True)[1].max() > 2:
        raise ValueError("an edge is used by more than two faces: split_nonmanifold first")
    f1, f2, same = _interior_pairs(F, n)
    ncomp, labels = connected_components(
        sp.coo_array((np.ones(f1.size), (f1, f2)), shape=(m, m)), directed=False
    )
    first = np.full(ncomp, m, dtype=np.int64)
    np.minimum.at(first, labels, np.arange(m))
    root = m  # virtual root joined to the first face of every component
    u = np.concatenate([f1, np.full(ncomp, root)])
    v = np.concatenate([f2, first])
    G = sp.coo_array((np.ones(u.size), (u, v)), shape=(m + 1, m + 1)).tocsr()
    _, pred = breadth_first_order(G + G.T, root, directed=True, return_predecessors=True)
    pred = pred[:m].astype(np.int64)
    # parity of each tree edge (face, its parent): 1 when they conflict
    conflict = sp.coo_array(
        (np.r_[same, same].astype(np.float64) + 1.0, (np.r_[f1, f2], np.r_[f2, f1])),
        shape=(m, m),
    ).tocsr()
    parity = np.zeros(m, dtype=bool)
    tree = pred >= 0
    tree &= pred != root
    idx = np.flatnonzero(tree)
    parity[idx] = np.asarray(conflict[idx, pred[idx]]).ravel() > 1.5
    anc = np.where(tree, pred, -1)
    while np.any(anc >= 0):  # pointer jumping: parity to the component's first face
        live = np.flatnonzero(anc >= 0)
        parity[live] ^= parity[anc[live]]
        anc[live] = anc[anc[live]]
    # keep the majority's orientation in each component
    ones = np.bincount(labels, weights=parity, minlength=ncomp)
    size = np.bincount(labels, minlength=ncomp)
    flip = parity ^ (ones > size - ones)[labels]
    out = F.copy()
    out[flip] = out[flip][:, [0, 2, 1]]
    _, _, still = _interior_pairs(out, n)
    return OrientedFaces(out, flip, int(still.sum()))
