"""Mutual nearest vertices: the target's own vertices as tangential correspondences.

Closest points on the target surface carry a deformed source only along the normal:
once it lies on the target, nothing in them says where along the surface a vertex
belongs, and the non-rigid ICP's smoothness prior decides (issue 27: features slide).
The target's vertices do say it where the two meshes sample the surface alike (a
re-ordered or re-triangulated export of one rig, a key and its subdivision, a scan and
its warp), which is what MeshMonk's symmetric push-pull matching of points uses. Here a
source vertex v and a target vertex j are paired when each is the other's nearest
vertex, they are within a distance, and their normals agree; paired source vertices get
the target vertex as an extra correspondence (blended with the closest point by
:func:`conformorph.geometry.nonrigid_icp.nonrigid_icp`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ._typing import BoolArray, FloatArray, IntArray


def _points_with_normals(
    V: FloatArray, N: FloatArray, name: str, count: str
) -> tuple[FloatArray, FloatArray]:
    """``V`` and its normals ``N`` as float64, both (count, 3) with count ≥ 1, or
    ValueError naming them (``name`` and its ``…_normals``)."""
    P = np.asarray(V, dtype=np.float64)
    Q = np.asarray(N, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or Q.shape != P.shape or P.shape[0] == 0:
        normals = name.replace("_V", "_normals")
        raise ValueError(
            f"{name} and {normals} must both be ({count}, 3), {count} ≥ 1, got "
            f"{P.shape} and {Q.shape}"
        )
    return P, Q


@dataclass(frozen=True)
class VertexPairs:
    """Mutual nearest vertex pairs of a source and a target point set.

    Attributes
    ----------
    target : (n,) int64
        Every source vertex's nearest target vertex.
    paired : (n,) bool
        Source vertices whose nearest target vertex has them as its nearest source
        vertex, within the distance, normals agreeing.
    """

    target: IntArray
    paired: BoolArray


class MutualNearestVertices:
    """Pairs of mutual nearest vertices between moving source points and a fixed target.

    Parameters
    ----------
    target_V : (n_t, 3) float64
        Target vertices (their k-d tree is built once).
    target_normals : (n_t, 3) float64
        Their unit normals.
    """

    def __init__(self, target_V: FloatArray, target_normals: FloatArray) -> None:
        T, N = _points_with_normals(target_V, target_normals, "target_V", "n_t")
        self.V = T
        self.normals = N
        self._tree = cKDTree(T)

    def pairs(
        self,
        source_V: FloatArray,
        source_normals: FloatArray,
        max_distance: float,
        min_normal_cosine: float,
    ) -> VertexPairs:
        """Mutual nearest pairs of ``source_V`` (n, 3) with the target.

        Parameters
        ----------
        source_V : (n, 3) float64
        source_normals : (n, 3) float64
            Unit normals of the source vertices.
        max_distance : float
            Pairs farther apart are dropped.
        min_normal_cosine : float
            Pairs whose normals' cosine is below this are dropped.

        Returns
        -------
        VertexPairs
        """
        Y, Ny = _points_with_normals(source_V, source_normals, "source_V", "n")
        dist, to_target = self._tree.query(Y)
        _, to_source = cKDTree(Y).query(self.V)
        to_target = np.asarray(to_target, dtype=np.int64)
        mutual = to_source[to_target] == np.arange(Y.shape[0])
        cos = np.einsum("ij,ij->i", Ny, self.normals[to_target])
        paired = mutual & (dist <= max_distance) & (cos >= min_normal_cosine)
        return VertexPairs(to_target, np.asarray(paired, dtype=bool))
