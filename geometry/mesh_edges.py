"""Edge incidence of a triangle mesh: unique edges, face counts, boundary edges."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import IntArray


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
