"""Locate points in a planar triangulation and give their barycentric coordinates.

Used to resample per-vertex data (H, λ, positions, colours, UVs) of one disk
parameterisation at arbitrary points of the disk (section 4 of the face
morphing paper: :math:`q = \\sum_j \\beta_{i,j}(q) V_{F_i^{(j)}}`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ._typing import BoolArray, FloatArray, IntArray

#: barycentric coordinates down to this (relative) negative value count as inside
_INSIDE_TOL = 1e-10
#: number of nearest triangle centroids tried in each round
_ROUNDS = (8, 32, 128)


@dataclass(frozen=True)
class PointLocation:
    """Result of :func:`locate_points`.

    Attributes
    ----------
    triangle : (p,) int64
        Index of the triangle holding (or nearest to) each point.
    barycentric : (p, 3) float64
        Barycentric coordinates in that triangle; non-negative, summing to 1.
        For a point outside the triangulation they are those of the nearest
        point of the triangulation (the point is snapped onto it).
    distance : (p,) float64
        Distance from the point to the triangulation; 0 inside.
    """

    triangle: IntArray
    barycentric: FloatArray
    distance: FloatArray

    @property
    def inside(self) -> BoolArray:
        """(p,) bool: points that lie in the triangulation (distance 0)."""
        return np.asarray(self.distance == 0.0)

    def interpolate(self, F: IntArray, values: FloatArray) -> FloatArray:
        """Barycentric interpolation of per-vertex values at the located points.

        Parameters
        ----------
        F : (m, 3) int64
            The triangles the points were located in.
        values : (n,) or (n, d) float64
            Per-vertex values of the triangulation.

        Returns
        -------
        (p,) or (p, d) float64
        """
        values = np.asarray(values)
        idx = F[self.triangle]  # (p, 3)
        w = self.barycentric
        if values.ndim == 1:
            return np.asarray(np.einsum("pj,pj->p", w, values[idx]))
        return np.asarray(np.einsum("pj,pj...->p...", w, values[idx]))


def _barycentric(
    a: FloatArray, b: FloatArray, c: FloatArray, x: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Barycentric coordinates of x in triangles (a, b, c); broadcasting over leading axes."""
    v0 = b - a
    v1 = c - a
    v2 = x - a
    det = v0[..., 0] * v1[..., 1] - v0[..., 1] * v1[..., 0]
    safe = np.where(np.abs(det) > 0, det, 1.0)
    l1 = (v2[..., 0] * v1[..., 1] - v2[..., 1] * v1[..., 0]) / safe
    l2 = (v0[..., 0] * v2[..., 1] - v0[..., 1] * v2[..., 0]) / safe
    lam = np.stack([1.0 - l1 - l2, l1, l2], axis=-1)
    return lam, det


def _closest_on_triangles(
    a: FloatArray, b: FloatArray, c: FloatArray, x: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Distance from x to the boundary of triangles (a, b, c) and the barycentrics of the nearest point."""
    shape = np.broadcast_shapes(a.shape, x.shape)[:-1]
    best_d = np.full(shape, np.inf)
    best_w = np.zeros(shape + (3,))
    corners = (a, b, c)
    for i in range(3):
        p, q = corners[i], corners[(i + 1) % 3]
        e = q - p
        ee = np.einsum("...k,...k->...", e, e)
        s = np.einsum("...k,...k->...", x - p, e) / np.where(ee > 0, ee, 1.0)
        s = np.clip(s, 0.0, 1.0)
        y = p + s[..., None] * e
        d = np.linalg.norm(x - y, axis=-1)
        better = d < best_d
        w = np.zeros(shape + (3,))
        w[..., i] = 1.0 - s
        w[..., (i + 1) % 3] = s
        best_d = np.where(better, d, best_d)
        best_w = np.where(better[..., None], w, best_w)
    return best_d, best_w


class PointLocator:
    """A planar triangulation prepared for repeated point location.

    Parameters
    ----------
    uv : (n, 2) float64
        Vertex positions in the plane.
    F : (m, 3) int64
        Triangles. Flipped or overlapping triangles are tolerated: a point
        covered by several triangles gets one of them.

    Notes
    -----
    A KD-tree of triangle centroids proposes, for every query point, its
    k nearest triangles (k = 8, then 32, then 128 for the points not yet
    found); barycentric coordinates decide containment, all vectorised. A
    point outside every proposed triangle is snapped to the nearest point of
    the nearest proposed triangle (those are the points just outside the
    polygonal boundary of an inscribed disk mesh). Cost: O(p k log m).
    """

    def __init__(self, uv: FloatArray, F: IntArray) -> None:
        uv = np.asarray(uv, dtype=np.float64)
        F = np.asarray(F, dtype=np.int64)
        if uv.ndim != 2 or uv.shape[1] != 2:
            raise ValueError(f"uv must have shape (n, 2), got {uv.shape}")
        if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] == 0:
            raise ValueError(f"F must have shape (m, 3) with m ≥ 1, got {F.shape}")
        if F.min() < 0 or F.max() >= uv.shape[0]:
            raise ValueError(f"F indexes vertices outside 0..{uv.shape[0] - 1}")
        if not np.all(np.isfinite(uv)):
            raise ValueError("uv has non-finite coordinates")
        self.uv = uv.copy()
        self.F = F.copy()
        self._corners = self.uv[self.F]  # (m, 3, 2)
        self._tree = cKDTree(self._corners.mean(axis=1))

    def locate(self, points: FloatArray) -> PointLocation:
        """Locate points.

        Parameters
        ----------
        points : (p, 2) float64

        Returns
        -------
        PointLocation
        """
        x = np.asarray(points, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != 2:
            raise ValueError(f"points must have shape (p, 2), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("points have non-finite coordinates")
        p = x.shape[0]
        m = self.F.shape[0]
        tri = np.full(p, -1, dtype=np.int64)
        bary = np.zeros((p, 3))
        dist = np.zeros(p)
        todo = np.arange(p)
        for k in _ROUNDS:
            if todo.size == 0:
                break
            kk = min(k, m)
            cand = self._candidates(x[todo], kk)
            c = self._corners[cand]  # (t, k, 3, 2)
            lam, det = _barycentric(c[..., 0, :], c[..., 1, :], c[..., 2, :], x[todo, None, :])
            ok = (lam >= -_INSIDE_TOL).all(axis=-1) & (np.abs(det) > 0)
            hit = ok.any(axis=1)
            first = np.argmax(ok, axis=1)
            rows = np.nonzero(hit)[0]
            sel = todo[rows]
            tri[sel] = cand[rows, first[rows]]
            w = np.clip(lam[rows, first[rows]], 0.0, None)
            bary[sel] = w / w.sum(axis=1, keepdims=True)
            todo = todo[~hit]
            if kk == m:
                break
        if todo.size:
            # outside the triangulation: snap to the nearest point of the nearest candidates
            cand = self._candidates(x[todo], _ROUNDS[-1])
            c = self._corners[cand]
            d, w = _closest_on_triangles(c[..., 0, :], c[..., 1, :], c[..., 2, :], x[todo, None, :])
            j = np.argmin(d, axis=1)
            r = np.arange(todo.size)
            tri[todo] = cand[r, j]
            bary[todo] = w[r, j]
            dist[todo] = d[r, j]
        return PointLocation(tri, bary, dist)

    def _candidates(self, x: FloatArray, k: int) -> IntArray:
        kk = min(k, self.F.shape[0])
        _, cand = self._tree.query(x, k=kk)
        return np.asarray(cand, dtype=np.int64).reshape(x.shape[0], kk)


def locate_points(uv: FloatArray, F: IntArray, points: FloatArray) -> PointLocation:
    """Locate points in a planar triangulation (one-shot form of :class:`PointLocator`).

    Parameters
    ----------
    uv : (n, 2) float64
        Vertex positions of the triangulation.
    F : (m, 3) int64
        Triangles.
    points : (p, 2) float64
        Query points.

    Returns
    -------
    PointLocation
        Triangle index, barycentric coordinates (non-negative, sum 1) and the
        distance to the triangulation (0 inside; outside points are snapped to
        the nearest point of the triangulation).

    Examples
    --------
    >>> import numpy as np
    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> loc = locate_points(uv, np.array([[0, 1, 2]]), np.array([[0.25, 0.5]]))
    >>> loc.barycentric.round(3).tolist()
    [[0.25, 0.25, 0.5]]
    """
    return PointLocator(uv, F).locate(points)
