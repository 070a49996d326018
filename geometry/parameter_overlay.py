"""The overlay of two parameterisations of one polygon: its size, edges meeting a triangle, re-triangulation."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ._typing import BoolArray, FloatArray, IntArray
from .point_location import PointLocator
from .triangulate_shape import triangulate_segments


def _unique_edges(F: IntArray) -> IntArray:
    E = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    return np.asarray(np.unique(E, axis=0), dtype=np.int64)


def _proper_crossings(
    a0: FloatArray, a1: FloatArray, b0: FloatArray, b1: FloatArray
) -> tuple[IntArray, IntArray, FloatArray]:
    """Pairs (i, j) of segments a_i, b_j crossing at an inner point of both, and the points."""
    ca, cb = 0.5 * (a0 + a1), 0.5 * (b0 + b1)
    ra = 0.5 * np.linalg.norm(a1 - a0, axis=1)
    rb = 0.5 * np.linalg.norm(b1 - b0, axis=1)
    tree = cKDTree(cb)
    pairs = tree.query_ball_point(ca, ra + (rb.max() if rb.size else 0.0))
    I = np.repeat(np.arange(len(pairs)), [len(p) for p in pairs]).astype(np.int64)
    J = np.concatenate([np.asarray(p, dtype=np.int64) for p in pairs]) if len(pairs) else I
    if I.size == 0:
        return I, J, np.zeros((0, 2))
    d = a1[I] - a0[I]
    e = b1[J] - b0[J]
    den = d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]
    w = b0[J] - a0[I]
    safe = np.where(den != 0, den, 1.0)
    s = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / safe
    t = (w[:, 0] * d[:, 1] - w[:, 1] * d[:, 0]) / safe
    eps = 1e-9
    ok = (den != 0) & (s > eps) & (s < 1 - eps) & (t > eps) & (t < 1 - eps)
    return I[ok], J[ok], a0[I[ok]] + s[ok, None] * d[ok]


def overlay_triangle_count(
    uv_s: FloatArray, F_s: IntArray, uv_t: FloatArray, F_t: IntArray, nb: int
) -> int:
    """Triangles of a triangulated overlay of two triangulations of the same convex polygon.

    Parameters
    ----------
    uv_s, uv_t : (n_s, 2), (n_t, 2) float64
        Vertices; the first ``nb`` of each are the shared polygon corners.
    F_s, F_t : (m_s, 3), (m_t, 3) int64
    nb : int

    Returns
    -------
    int
        ``2 V_o − nb − 2`` (Euler's formula for a triangulated polygon) with
        ``V_o = n_s + n_t − nb + X`` the overlay's vertices, X the proper
        crossings of edges of one triangulation with edges of the other.
        This is the size an edge-intersection method (the paper's refs. 9, 18)
        produces, against which the compatible triangulation is compared.

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])
    >>> overlay_triangle_count(sq, np.array([[0, 1, 2], [0, 2, 3]]), sq, np.array([[0, 1, 3], [1, 2, 3]]), 4)
    4
    """
    Es, Et = _unique_edges(F_s), _unique_edges(F_t)
    _, _, X = _proper_crossings(uv_s[Es[:, 0]], uv_s[Es[:, 1]], uv_t[Et[:, 0]], uv_t[Et[:, 1]])
    v = uv_s.shape[0] + uv_t.shape[0] - nb + X.shape[0]
    return int(2 * v - nb - 2)


def _edges_meeting_triangle(tri: FloatArray, uv: FloatArray, E: IntArray) -> BoolArray:
    """(e,) bool: edges ``E`` of a triangulation ``uv`` that meet the inside of triangle ``tri`` (3, 2).

    An edge meets it when an end lies strictly inside or the edge properly
    crosses a side: exactly the edges along which a piecewise-linear map on
    that triangulation can bend inside ``tri``.
    """
    a, b, c = tri
    det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if det == 0:
        return np.zeros(E.shape[0], dtype=bool)
    d = uv - a
    l1 = (d[:, 0] * (c[1] - a[1]) - d[:, 1] * (c[0] - a[0])) / det
    l2 = ((b[0] - a[0]) * d[:, 1] - (b[1] - a[1]) * d[:, 0]) / det
    inside = (l1 > 1e-12) & (l2 > 1e-12) & (1 - l1 - l2 > 1e-12)
    hit = inside[E[:, 0]] | inside[E[:, 1]]
    p0, p1 = uv[E[:, 0]], uv[E[:, 1]]
    e = p1 - p0
    for s in range(3):
        q0, q1 = tri[s], tri[(s + 1) % 3]
        f = q1 - q0
        den = e[:, 0] * f[1] - e[:, 1] * f[0]
        w = q0 - p0
        safe = np.where(den != 0, den, 1.0)
        u = (w[:, 0] * f[1] - w[:, 1] * f[0]) / safe
        v = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / safe
        hit |= (den != 0) & (u > 1e-12) & (u < 1 - 1e-12) & (v > 1e-12) & (v < 1 - 1e-12)
    return np.asarray(hit)


def _vertices_inside_triangle(tri: FloatArray, uv: FloatArray) -> IntArray:
    """Indices of the points ``uv`` strictly inside triangle ``tri`` (3, 2), either orientation."""
    a, b, c = tri
    det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if det == 0:
        return np.zeros(0, dtype=np.int64)
    d = uv - a
    l1 = (d[:, 0] * (c[1] - a[1]) - d[:, 1] * (c[0] - a[0])) / det
    l2 = ((b[0] - a[0]) * d[:, 1] - (b[1] - a[1]) * d[:, 0]) / det
    return np.flatnonzero((l1 > 1e-12) & (l2 > 1e-12) & (1 - l1 - l2 > 1e-12))


def _triangulate_deduplicated(verts: FloatArray, segs: IntArray) -> tuple[FloatArray, IntArray]:
    """:func:`triangulate_segments` after merging coincident vertices (first copy kept).

    Output vertex i < len(verts) is input vertex i (a merged copy takes its
    first copy's position and is unreferenced), so indices stay valid.
    """
    scale = float(np.abs(verts).max()) or 1.0
    _, first, inv = np.unique(
        np.round(verts / scale, 11), axis=0, return_index=True, return_inverse=True
    )
    inv = inv.reshape(-1)
    rep = first[inv]  # each vertex's first copy
    keep = np.sort(first)
    newidx = np.full(verts.shape[0], -1, dtype=np.int64)
    newidx[keep] = np.arange(keep.size)
    s = newidx[rep[segs]]
    s = s[s[:, 0] != s[:, 1]]
    s = np.unique(np.sort(s, axis=1), axis=0)
    V, F = triangulate_segments(verts[keep], s)
    # back to the caller's numbering: kept vertices at their own index, Steiner points after
    out_idx = np.concatenate([keep, verts.shape[0] + np.arange(V.shape[0] - keep.size)])
    X = np.zeros((verts.shape[0] + V.shape[0] - keep.size, 2))
    X[: verts.shape[0]] = verts[rep]
    X[out_idx] = V
    return X, out_idx[F]


def _map_back(loc: PointLocator, F: IntArray, X: FloatArray, P: FloatArray) -> FloatArray:
    return np.asarray(loc.locate(P).interpolate(F, X), dtype=np.float64)
