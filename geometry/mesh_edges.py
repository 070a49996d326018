"""Edge incidence of a triangle mesh: unique edges, face counts, boundary edges and vertices."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import BoolArray, IntArray


@dataclass(frozen=True)
class MeshEdges:
    """Unique undirected edges of a triangle mesh.

    Attributes
    ----------
    edges : (e, 2) int64
        Unique edges, each sorted (``edges[:, 0] < edges[:, 1]``).
    face_count : (e,) int64
        Number of faces that use each edge.
    halfedge_edge : (m, 3) int64
        Index into ``edges`` of the half-edge ``(F[f, k], F[f, k+1])``.
    """

    edges: IntArray
    face_count: IntArray
    halfedge_edge: IntArray

    @property
    def boundary(self) -> IntArray:
        """(k, 2) int64: edges used by exactly one face."""
        return self.edges[self.face_count == 1]


def mesh_edges(F: IntArray) -> MeshEdges:
    """Unique edges of the triangles ``F`` and how many faces use each.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles.

    Returns
    -------
    MeshEdges
    """
    tail, head = F.reshape(-1), np.roll(F, -1, axis=1).reshape(-1)
    # elementwise min/max of two vectors: several times faster than min(axis=1) of (3m, 2)
    lo, hi = np.minimum(tail, head), np.maximum(tail, head)
    n = int(F.max()) + 1 if F.size else 0
    # encode each undirected edge as one int64: 1D unique is ~10x faster than axis=0
    keys, inverse, counts = np.unique(lo * n + hi, return_inverse=True, return_counts=True)
    edges = np.stack(np.divmod(keys, n), axis=1)
    return MeshEdges(
        edges=edges.astype(np.int64),
        face_count=counts.astype(np.int64),
        halfedge_edge=inverse.reshape(F.shape).astype(np.int64),
    )


def mesh_boundary_vertices(F: IntArray, n: int) -> BoolArray:
    """Vertices on an edge that only one triangle uses.

    Parameters
    ----------
    F : (m, 3) int64
    n : int
        Number of vertices (≥ every index in ``F`` + 1).

    Returns
    -------
    (n,) bool

    Examples
    --------
    >>> import numpy as np
    >>> F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    >>> mesh_boundary_vertices(F, 5).tolist()
    [False, True, True, True, True]
    """
    F = np.asarray(F, dtype=np.int64)
    if F.ndim != 2 or F.shape[1] != 3:
        raise ValueError(f"F must have shape (m, 3), got {F.shape}")
    if F.size and (F.min() < 0 or F.max() >= n):
        raise ValueError(f"F indexes vertices outside 0..{n - 1}")
    on = np.zeros(n, dtype=bool)
    on[mesh_edges(F).boundary.ravel()] = True
    return on
