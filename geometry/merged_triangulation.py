"""The merged triangulation of two parameterisations, refined where a triangle flips.

The inner points of both shapes' parameterisations are merged (points closer
than half the local spacing are merged), triangulated in the polygon
(constrained Delaunay) and mapped back through each parameterisation. Every
triangle flipped in either shape after the cheap edge-flip repair is refined:
first the parameterisation's vertices inside it, then the edges meeting it,
become part of the merged set (a local overlay), until nothing flips.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ._typing import FloatArray, IntArray
from .flip_repair import _areas, _edge_flips
from .mean_value_patches import PatchMaps
from .parameter_overlay import (
    _edges_meeting_triangle,
    _map_back,
    _triangulate_deduplicated,
    _unique_edges,
    _vertices_inside_triangle,
)
from .point_location import PointLocator


class MergedPoints:
    """The merged point set in the polygon, keyed by (shape, vertex) so refinement can add to it.

    Parameters
    ----------
    maps : PatchMaps
        Both parameterisations (boundary entries 0 … nb−1, then ``n_in`` inner
        anchors, then the other inner vertices).
    n_in : int
        Number of inner anchors, placed at the mean of their two images.

    Attributes
    ----------
    points : list of (2,) float64
        The merged points (not the polygon's corners).
    merged : int
        Inner points dropped because a point of the other shape, or a fixed
        point, was closer than half the local spacing.
    initial : int
        Size of the set before any refinement.
    """

    def __init__(self, maps: PatchMaps, n_in: int) -> None:
        uvs, circle = maps.uvs, maps.circle
        nb = circle.shape[0]
        self.uvs, self.nb = uvs, nb
        anchor_uv = 0.5 * (uvs[0][nb : nb + n_in] + uvs[1][nb : nb + n_in])
        P_s, P_t = uvs[0][nb + n_in :], uvs[1][nb + n_in :]
        fixed_pts = np.vstack([circle, anchor_uv]) if n_in else circle
        sp_s, sp_t = _spacing(P_s), _spacing(P_t)
        keep_s = np.ones(P_s.shape[0], dtype=bool)
        keep_t = np.ones(P_t.shape[0], dtype=bool)
        if P_s.shape[0] and P_t.shape[0]:
            dist, nn = cKDTree(P_s).query(P_t)
            keep_t = dist >= 0.5 * np.minimum(sp_t, sp_s[nn])
        apothem = np.cos(np.pi / max(nb, 3))
        for P, hh0, keep in ((P_s, sp_s, keep_s), (P_t, sp_t, keep_t)):
            if P.shape[0]:
                hh = np.minimum(hh0, 0.5 * apothem)
                keep &= (apothem - np.linalg.norm(P, axis=1) > 0.0) & (
                    cKDTree(fixed_pts).query(P)[0] >= 0.5 * hh
                )
        self.merged = int((~keep_s).sum() + (~keep_t).sum())
        self.points: list[FloatArray] = [anchor_uv[i] for i in range(n_in)]
        self.reg: dict[tuple[int, int], int] = {}
        for k, keep in ((0, keep_s), (1, keep_t)):
            for ii in np.flatnonzero(keep).tolist():
                self.reg[(k, nb + n_in + ii)] = len(self.points)
                self.points.append(uvs[k][nb + n_in + ii])
        self.initial = len(self.points)

    def index(self, k: int, i: int) -> int:
        """Merged-triangulation index of vertex i of shape k's parameterisation (added if new)."""
        if i < self.nb:
            return i
        if (k, i) not in self.reg:
            self.reg[(k, i)] = len(self.points)
            self.points.append(self.uvs[k][i])
        return self.nb + self.reg[(k, i)]


def _spacing(P: FloatArray) -> FloatArray:
    """Distance of each point to its nearest other point (inf for fewer than two)."""
    if P.shape[0] < 2:
        return np.full(P.shape[0], np.inf)
    return np.asarray(cKDTree(P).query(P, k=2)[0][:, 1], dtype=np.float64)


def refined_merged_triangulation(
    maps: PatchMaps,
    points: MergedPoints,
    inner_anchors: FloatArray,
    max_refinements: int,
) -> tuple[FloatArray, IntArray, list[FloatArray], int]:
    """Triangulate the merged points, map back, and refine where a triangle flips (local overlay).

    Each round: constrained Delaunay triangulation of the polygon's corners
    and the merged points (with the parameterisations' edges used so far as
    constraints; Triangle inserts their crossings), map back through each
    parameterisation, edge flips valid in both meshes (the paper's repair),
    then every triangle still flipped in shape k adds shape k's vertices inside
    it or, failing that, the edges meeting it.

    Parameters
    ----------
    maps : PatchMaps
    points : MergedPoints
        Extended in place by the refinement.
    inner_anchors : (i, 2, 2) float64
        Positions imposed on the inner anchors in each shape.
    max_refinements : int

    Returns
    -------
    UV : (k, 2) float64
        The merged triangulation's vertices in the polygon.
    F : (m, 3) int64
    Xd : list of (k, 2) float64
        Its vertices mapped back into the source and the target disk.
    refinements : int
        Rounds of refinement done.
    """
    meshes, uvs, circle = maps.meshes, maps.uvs, maps.circle
    nb = circle.shape[0]
    n_in = inner_anchors.shape[0]
    locators = [PointLocator(uvs[k], meshes[k][1]) for k in (0, 1)]
    edges = [_unique_edges(meshes[k][1]) for k in (0, 1)]
    ring = np.c_[np.arange(nb), (np.arange(nb) + 1) % nb]
    used = [np.zeros(e.shape[0], dtype=bool) for e in edges]
    refinements = 0
    vidx = points.index
    while True:
        con = np.vstack(
            [ring]
            + [
                np.array(
                    [[vidx(k, int(i)), vidx(k, int(j))] for i, j in edges[k][used[k]]],
                    dtype=np.int64,
                ).reshape(-1, 2)
                for k in (0, 1)
            ]
        )
        UV, F = _triangulate_deduplicated(
            np.vstack([circle, np.array(points.points).reshape(-1, 2)]), con
        )
        Xd = []
        for k in (0, 1):
            X = np.zeros((UV.shape[0], 2))
            X[:nb] = meshes[k][0][:nb]
            X[nb:] = _map_back(locators[k], meshes[k][1], meshes[k][0], UV[nb:])
            if n_in:
                X[nb : nb + n_in] = inner_anchors[:, k]
            Xd.append(X)
        # cheap repair first (the paper's edge flips, valid in both meshes); only
        # the triangles it cannot fix are refined
        for _ in range(8):
            bad_any = np.union1d(
                np.flatnonzero(_areas(Xd[0], F) <= 0), np.flatnonzero(_areas(Xd[1], F) <= 0)
            )
            if bad_any.size == 0:
                break
            F, done = _edge_flips(Xd[0], Xd[1], F, bad_any)
            if done == 0:
                break
        bad = [np.flatnonzero(_areas(Xd[k], F) <= 0) for k in (0, 1)]
        if refinements >= max_refinements or (bad[0].size == 0 and bad[1].size == 0):
            break
        grew = False
        for k in (0, 1):
            for f in bad[k]:
                found = _vertices_inside_triangle(UV[F[f]], uvs[k]).tolist()
                fresh = [v for v in found if v >= nb and (k, v) not in points.reg]
                if fresh:  # first the kinks at the map's vertices
                    for v in fresh:
                        vidx(k, v)
                    grew = True
                    continue
                hit = _edges_meeting_triangle(UV[F[f]], uvs[k], edges[k]) & ~used[k]
                if np.any(hit):  # then its edges
                    used[k] |= hit
                    grew = True
        if not grew:
            break
        refinements += 1
    return UV, F, Xd, refinements
