"""Constrained Delaunay triangulation of a planar shape (outer ring and holes) with ``triangle``."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ._typing import FloatArray, IntArray
from .shape_rings import ShapeRings, points_in_ring


def triangulate_polygon(
    boundary: FloatArray,
    *,
    holes: tuple[FloatArray, ...] = (),
    points: ArrayLike | None = None,
    max_area: float | None = None,
    min_angle: float | None = None,
) -> tuple[FloatArray, IntArray]:
    """Triangulate the inside of closed rings, never splitting a boundary edge.

    Parameters
    ----------
    boundary : (k, 2) float64
        Outer ring, counter-clockwise; these vertices come first in the output, in order.
    holes : tuple of (k_i, 2) float64, optional
        Hole rings; their vertices follow the outer ring's, in order.
    points : (p, 2) float64, optional
        Extra interior vertices, kept (after the ring vertices) in order.
    max_area : float, optional
        Largest triangle area (Steiner points added inside, never on the
        boundary). Triangle cannot refine next to a boundary segment longer
        than about ``sqrt(2 max_area)`` without splitting it, which switch
        ``Y`` forbids; split long boundary edges first when the bound matters.
    min_angle : float, optional
        Smallest angle in degrees for quality refinement (≤ 30 is safe).

    Returns
    -------
    V : (n, 2) float64
        Ring vertices, then ``points``, then any Steiner points.
    F : (m, 3) int64
        Counter-clockwise triangles inside the outer ring and outside the holes.

    Notes
    -----
    Uses J. R. Shewchuk's Triangle through the ``triangle`` package (imported
    here, so that ``geometry`` itself imports with numpy and scipy alone),
    with the switches ``p`` (constrained), ``Y`` (no Steiner points on
    segments), ``q``/``a`` when asked. Triangles whose centroid lies in a hole
    are removed, as in the paper's "scan line" step, and so are vertices left
    unreferenced by that.
    """
    import triangle  # noqa: PLC0415 - optional heavy import kept local

    rings = (
        np.asarray(boundary, dtype=np.float64),
        *(np.asarray(h, dtype=np.float64) for h in holes),
    )
    verts = [r for r in rings]
    segs = []
    off = 0
    for r in rings:
        k = r.shape[0]
        segs.append(np.c_[np.arange(k), (np.arange(k) + 1) % k] + off)
        off += k
    if points is not None:
        P = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        verts.append(P)
    V_in = np.vstack(verts)
    opts = "pYQ"
    if min_angle is not None:
        opts += f"q{min_angle:g}"
    if max_area is not None:
        opts += f"a{max_area:.17g}"
    out = triangle.triangulate({"vertices": V_in, "segments": np.vstack(segs)}, opts)
    V = np.asarray(out["vertices"], dtype=np.float64)
    F = np.asarray(out["triangles"], dtype=np.int64)
    if holes:
        c = V[F].mean(axis=1)
        keep = np.ones(F.shape[0], dtype=bool)
        for h in rings[1:]:
            keep &= ~points_in_ring(h, c)
        F = F[keep]
        used = np.zeros(V.shape[0], dtype=bool)
        used[F.ravel()] = True
        used[: V_in.shape[0]] = True  # input vertices keep their indices
        if not np.all(used):
            new = np.cumsum(used) - 1
            V, F = V[used], new[F]
    e1 = V[F[:, 1]] - V[F[:, 0]]
    e2 = V[F[:, 2]] - V[F[:, 0]]
    cw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    F[cw] = F[cw][:, [0, 2, 1]]
    return V, F


def triangulate_shape(
    shape: ShapeRings, *, max_area: float | None = None, min_angle: float | None = None
) -> tuple[FloatArray, IntArray]:
    """Triangulate a validated shape; see :func:`triangulate_polygon`.

    Parameters
    ----------
    shape : ShapeRings
    max_area : float, optional
    min_angle : float, optional

    Returns
    -------
    V : (n, 2) float64
        Outer-ring vertices first, then hole vertices, then Steiner points.
    F : (m, 3) int64
    """
    return triangulate_polygon(
        shape.outer, holes=shape.holes, max_area=max_area, min_angle=min_angle
    )


def triangulate_segments(
    vertices: FloatArray,
    segments: IntArray,
    *,
    hole_points: FloatArray | None = None,
    points: ArrayLike | None = None,
    max_area: float | None = None,
    min_angle: float | None = None,
    split_inner_segments: bool = True,
) -> tuple[FloatArray, IntArray]:
    """Constrained Delaunay triangulation of a planar straight-line graph.

    Parameters
    ----------
    vertices : (k, 2) float64
        Graph vertices; they come first in the output, in order. A vertex equal to an
        earlier one is merged into it (its segments become the earlier one's, a segment
        between the two is dropped; it stays in the output, in no triangle).
    segments : (s, 2) int64
        Constrained edges between ``vertices`` (rings and any inner cuts);
        no two may cross.
    hole_points : (h, 2) float64, optional
        One point strictly inside each hole; the region around it, bounded by
        segments, is left empty (Triangle's hole markers).
    points : (p, 2) float64, optional
        Extra vertices, kept after ``vertices`` in order.
    max_area, min_angle : float, optional
        Refinement bounds as in :func:`triangulate_polygon` (Steiner points
        never on a boundary segment).
    split_inner_segments : bool, optional
        Whether segments inside the domain may receive Steiner points (quality
        refinement; crossings of two segments always get one). ``False`` keeps
        every segment an edge (Triangle's ``YY``).

    Returns
    -------
    V : (n, 2) float64
        ``vertices``, then ``points``, then Steiner points.
    F : (m, 3) int64
        Counter-clockwise triangles of the region enclosed by the segments.
    """
    import triangle  # noqa: PLC0415 - optional heavy import kept local

    V_in = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
    if points is not None:
        V_in = np.vstack([V_in, np.asarray(points, dtype=np.float64).reshape(-1, 2)])
    # Triangle ignores a vertex that repeats another and leaves a segment naming it
    # undefined (a patch boundary with two equal consecutive points crashed the
    # process, in some runs only): it gets each point once, the repeats are put back
    # into the output in no triangle
    kept, place = _distinct_vertices(V_in)
    seg = place[np.asarray(segments, dtype=np.int64).reshape(-1, 2)]
    seg = seg[seg[:, 0] != seg[:, 1]]
    _, once = np.unique(np.sort(seg, axis=1), axis=0, return_index=True)
    data: dict[str, np.ndarray] = {
        "vertices": V_in[kept],
        "segments": seg[np.sort(once)].astype(np.int32),
    }
    if hole_points is not None and len(hole_points):
        data["holes"] = np.asarray(hole_points, dtype=np.float64).reshape(-1, 2)
    opts = "pYQ" if split_inner_segments else "pYYQ"
    if min_angle is not None:
        opts += f"q{min_angle:g}"
    if max_area is not None:
        opts += f"a{max_area:.17g}"
    out = triangle.triangulate(data, opts)
    k, kd = V_in.shape[0], kept.size
    V = np.vstack([V_in, np.asarray(out["vertices"], dtype=np.float64)[kd:]])
    F = np.asarray(out["triangles"], dtype=np.int64)
    F = np.where(F < kd, kept[np.minimum(F, kd - 1)], F - kd + k)
    e1 = V[F[:, 1]] - V[F[:, 0]]
    e2 = V[F[:, 2]] - V[F[:, 0]]
    cw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    F[cw] = F[cw][:, [0, 2, 1]]
    return V, F


def _distinct_vertices(V: FloatArray) -> tuple[IntArray, IntArray]:
    """``kept`` (k',): the rows of ``V`` that repeat no earlier row, and ``index`` (k,):
    each row's place among them (a repeat takes its first copy's place)."""
    _, first, inverse = np.unique(V, axis=0, return_index=True, return_inverse=True)
    canonical = first[np.ravel(inverse)]  # each row's first copy
    kept = np.flatnonzero(canonical == np.arange(V.shape[0]))
    place = np.zeros(V.shape[0], dtype=np.int64)
    place[kept] = np.arange(kept.size)
    return kept, place[canonical]


def point_inside_ring(ring: FloatArray) -> FloatArray:
    """A point strictly inside a simple ring (the centroid of an ear of its triangulation).

    Parameters
    ----------
    ring : (k, 2) float64

    Returns
    -------
    (2,) float64
    """
    V, F = triangulate_polygon(np.asarray(ring, dtype=np.float64)[:: 1 if _ccw(ring) else -1])
    areas = 0.5 * np.abs(
        (V[F[:, 1], 0] - V[F[:, 0], 0]) * (V[F[:, 2], 1] - V[F[:, 0], 1])
        - (V[F[:, 1], 1] - V[F[:, 0], 1]) * (V[F[:, 2], 0] - V[F[:, 0], 0])
    )
    return np.asarray(V[F[int(np.argmax(areas))]].mean(axis=0), dtype=np.float64)


def _ccw(ring: FloatArray) -> bool:
    r = np.asarray(ring, dtype=np.float64)
    x, y = r[:, 0], r[:, 1]
    return bool(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0)
