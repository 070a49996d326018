"""Feature points on the outer boundaries: arc-length parameters of rings and of the anchors on them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .shape_rings import (
    AnchorOutsideShapeError,
    ShapeError,
    ShapeRings,
    TooFewAnchorsError,
    distance_to_rings,
    points_in_shape,
)

#: An anchor within this fraction of the bounding-box diagonal of the ring
#: counts as lying on the boundary.
ANCHOR_ON_BOUNDARY_RTOL = 1e-3


def _ring_params(ring: FloatArray) -> tuple[FloatArray, float]:
    seg = np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    return cum, float(cum[-1])


def _project_on_ring(ring: FloatArray, p: FloatArray) -> tuple[float, FloatArray, float]:
    """Arc-length parameter in [0, L), closest point, distance.

    The closest point snaps to an end of its segment when it lies within a
    quarter of the segment *and* within ``ANCHOR_ON_BOUNDARY_RTOL`` of the
    ring's bounding-box diagonal of that end (an anchor meant to sit on a
    vertex, written with a few digits). A point further along a long segment
    keeps its place: a fixed quarter-segment rule moved an anchor placed at a
    tenth of a star's 150-unit edge onto the star's corner, and two such
    anchors onto the same corner.

    Parameters
    ----------
    ring : (k, 2) float64
        Closed ring (first point not repeated).
    p : (2,) float64

    Returns
    -------
    s : float
        Arc-length parameter of the closest point (after snapping).
    q : (2,) float64
        The closest point (after snapping).
    distance : float
        Distance from ``p`` to the ring (before snapping).
    """
    a, b = ring, np.roll(ring, -1, axis=0)
    e = b - a
    ee = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", p[None] - a, e) / ee, 0.0, 1.0)
    q = a + t[:, None] * e
    d = np.linalg.norm(q - p[None], axis=1)
    i = int(np.argmin(d))
    cum, _L = _ring_params(ring)
    ti = float(t[i])
    snap = ANCHOR_ON_BOUNDARY_RTOL * float(np.linalg.norm(np.ptp(ring, axis=0)))
    seg = float(np.sqrt(ee[i]))
    if ti < 0.25 and ti * seg <= snap:
        ti = 0.0
    elif ti > 0.75 and (1.0 - ti) * seg <= snap:
        ti, i = 0.0, (i + 1) % ring.shape[0]
    s = float(cum[i] + ti * np.sqrt(ee[i]) if ti > 0 else cum[i])
    return s, ring[i] + ti * e[i], float(d.min())


def _eval_ring(ring: FloatArray, s: FloatArray) -> FloatArray:
    cum, L = _ring_params(ring)
    s = np.mod(s, L)
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, ring.shape[0] - 1)
    seg = cum[i + 1] - cum[i]
    u = np.where(seg > 0, (s - cum[i]) / np.where(seg > 0, seg, 1.0), 0.0)
    nxt = np.roll(ring, -1, axis=0)
    return np.asarray(ring[i] + u[:, None] * (nxt[i] - ring[i]), dtype=np.float64)


def _ring_arc(ring: FloatArray, s0: float, s1: float) -> FloatArray:
    """The part of a closed ring from arc length s0 forward to s1 (a full loop if equal)."""
    cum, L = _ring_params(ring)
    length = (s1 - s0) % L
    if length <= 1e-12 * L:
        length = L
    inner = (cum[:-1] - s0) % L
    order = np.argsort(inner)
    keep = order[(inner[order] > 1e-12 * L) & (inner[order] < length - 1e-12 * L)]
    ends = _eval_ring(ring, np.array([s0, s0 + length]))
    return np.vstack([ends[:1], ring[keep], ends[1:]])


@dataclass(frozen=True)
class BoundaryAnchors:
    """The anchors on both outer boundaries, in source order, and the anchors inside.

    Attributes
    ----------
    bidx : (b,) int64
        Indices of the boundary anchors, sorted by their source parameter.
    s_par, t_par : (b,) float64
        Their arc-length parameters on the source and the target outer ring.
    inner : (i,) int64
        Indices of the anchors inside both shapes.
    """

    bidx: IntArray
    s_par: FloatArray
    t_par: FloatArray
    inner: IntArray


def boundary_anchors(
    source: ShapeRings, target: ShapeRings, anchors: FloatArray
) -> BoundaryAnchors:
    """Split the anchors into boundary feature points (with their arc-length parameters) and inner ones.

    An anchor lies on a boundary when within ``ANCHOR_ON_BOUNDARY_RTOL`` of the
    ring's bounding-box diagonal; it must then lie on both, and the boundary
    anchors must run in the same cyclic order along both outer rings.

    Parameters
    ----------
    source, target : ShapeRings
    anchors : (a, 2, 2) float64

    Returns
    -------
    BoundaryAnchors

    Raises
    ------
    ValueError
        Anchors of the wrong shape.
    AnchorOutsideShapeError
        An anchor outside its shape.
    ShapeError, TooFewAnchorsError
        An anchor on one boundary only, anchors in different orders or
        coincident, or no anchor on the boundaries.
    """
    if anchors.ndim != 3 or anchors.shape[1:] != (2, 2):
        raise ValueError(f"anchors must have shape (a, 2, 2), got {anchors.shape}")
    for side, shape in ((0, source), (1, target)):
        inside = points_in_shape(shape, anchors[:, side])
        if not np.all(inside):
            i = int(np.flatnonzero(~inside)[0])
            raise AnchorOutsideShapeError(
                f"anchor {i} {anchors[i, side].tolist()} lies outside the {'source' if side == 0 else 'target'} shape"
            )
    diag_s = float(np.linalg.norm(np.ptp(source.outer, axis=0)))
    diag_t = float(np.linalg.norm(np.ptp(target.outer, axis=0)))
    outer_s = ShapeRings(source.outer, (), ())
    outer_t = ShapeRings(target.outer, (), ())
    on_s = distance_to_rings(outer_s, anchors[:, 0]) <= ANCHOR_ON_BOUNDARY_RTOL * diag_s
    on_t = distance_to_rings(outer_t, anchors[:, 1]) <= ANCHOR_ON_BOUNDARY_RTOL * diag_t
    if np.any(on_s != on_t):
        i = int(np.flatnonzero(on_s != on_t)[0])
        raise ShapeError(f"anchor {i} lies on the boundary of one shape and inside the other")
    bidx = np.flatnonzero(on_s)
    if bidx.size == 0:
        raise TooFewAnchorsError(
            "at least one anchor must lie on the outer boundary of both shapes"
        )
    s_par = np.array([_project_on_ring(source.outer, anchors[i, 0])[0] for i in bidx])
    t_par = np.array([_project_on_ring(target.outer, anchors[i, 1])[0] for i in bidx])
    order = np.argsort(s_par)
    s_par, t_par, bidx = s_par[order], t_par[order], bidx[order]
    rot = np.argmin(t_par)
    if np.any(np.diff(np.roll(t_par, -rot)) <= 0):
        raise ShapeError("boundary anchors are in different orders along the two outer boundaries")
    if np.any(np.diff(s_par) <= 0):
        raise ShapeError("two boundary anchors coincide")
    return BoundaryAnchors(bidx, s_par, t_par, np.flatnonzero(~on_s))
