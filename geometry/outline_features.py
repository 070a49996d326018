"""Feature points of a closed outline: turning-angle extrema at a few arc-length scales.

A vertex's turning angle at scale ``h`` is the signed angle between the chord
arriving from the point an arc length ``h`` behind it and the chord leaving to
the point ``h`` ahead of it (both points interpolated on the ring). Measured on
arc length rather than on neighbouring vertices, it does not depend on how
densely the outline is sampled: a vertex in the middle of a straight side turns
by 0 however many vertices the side has, a corner turns by its angle at every
scale, and a round bend turns by the bend over the window. The features are
the vertices where ``|turning|`` is largest within the window at one of the
scales, above a threshold; their saliency is the largest ``|turning| / pi``
over the scales at which they are extrema.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._typing import BoolArray, FloatArray, IntArray


@dataclass(frozen=True)
class FeatureOptions:
    """Options of :func:`outline_features`.

    Attributes
    ----------
    scales : tuple of float
        Half-window arc lengths ``h`` as fractions of the perimeter
        (default 0.01, 0.025, 0.06).
    min_turning : float
        Smallest ``|turning|`` (radians) of a feature at any scale (default
        0.45, about 26 degrees).
    circle_factor : float
        A feature must also turn by more than this many times what a circle
        turns over the same window, ``4 pi h`` (default 1.5), so a round
        outline has no features.
    min_separation : float
        Features closer than this arc fraction to a more salient one are
        dropped (default 0.015).
    """

    scales: tuple[float, ...] = (0.01, 0.025, 0.06)  # finest first
    min_turning: float = 0.45
    circle_factor: float = 1.5
    min_separation: float = 0.015


@dataclass(frozen=True)
class OutlineFeatures:
    """Feature vertices of a ring, in order along it.

    Attributes
    ----------
    index : (k,) int64
        Ring vertex indices, increasing.
    arc : (k,) float64
        Arc-length position of each feature as a fraction of the perimeter,
        in [0, 1), measured from vertex 0 in the ring's order.
    turning : (k,) float64
        Signed turning angle (radians, positive turning left, i.e. convex on a
        counter-clockwise ring) where ``|turning|`` is largest (at the vertex
        or at a coarser extremum tracked to it).
    saliency : (k,) float64
        ``max |turning| / pi`` over the extrema tracked to the vertex, in (0, 1].
    """

    index: IntArray
    arc: FloatArray
    turning: FloatArray
    saliency: FloatArray


def ring_arc_positions(ring: ArrayLike) -> tuple[FloatArray, float]:
    """Arc-length position of each vertex of a closed ring.

    Parameters
    ----------
    ring : (n, 2) array_like
        Closed ring, last point not repeated.

    Returns
    -------
    s : (n,) float64
        Arc length from vertex 0 to each vertex, ``s[0] = 0``.
    perimeter : float
        Total length, closing edge included.

    Raises
    ------
    ValueError
        If ``ring`` is not (n, 2) with n >= 3, or its perimeter is 0.
    """
    P = _as_ring(ring)
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    perimeter = float(seg.sum())
    if not perimeter > 0:
        raise ValueError("ring has zero perimeter")
    return np.concatenate([[0.0], np.cumsum(seg[:-1])]), perimeter


def ring_points_at(ring: ArrayLike, arc: ArrayLike) -> FloatArray:
    """Points of a closed ring at given arc-length fractions (linear between vertices).

    Parameters
    ----------
    ring : (n, 2) array_like
    arc : (m,) array_like
        Positions as fractions of the perimeter from vertex 0; any real value
        (taken modulo 1).

    Returns
    -------
    (m, 2) float64
    """
    P = _as_ring(ring)
    s, perimeter = ring_arc_positions(P)
    q = np.mod(np.asarray(arc, dtype=np.float64), 1.0) * perimeter
    closed = np.vstack([P, P[:1]])
    sc = np.concatenate([s, [perimeter]])
    return np.column_stack([np.interp(q, sc, closed[:, 0]), np.interp(q, sc, closed[:, 1])])


def turning_angles(ring: ArrayLike, scale: float) -> FloatArray:
    """Signed turning angle at each vertex over an arc-length window.

    Parameters
    ----------
    ring : (n, 2) array_like
        Closed ring.
    scale : float
        Half-window ``h`` as a fraction of the perimeter, in (0, 0.5).

    Returns
    -------
    (n,) float64
        Angle (radians, in (-pi, pi]) from the chord ``p(s - h) -> p_i`` to
        the chord ``p_i -> p(s + h)``; positive turns left.

    Examples
    --------
    >>> sq = [[0, 0], [1, 0], [1, 1], [0, 1]]
    >>> np.round(turning_angles(sq, 0.05), 6).tolist()
    [1.570796, 1.570796, 1.570796, 1.570796]
    """
    if not 0 < scale < 0.5:
        raise ValueError(f"scale must be in (0, 0.5), got {scale}")
    P = _as_ring(ring)
    s, perimeter = ring_arc_positions(P)
    u = s / perimeter
    before = P - ring_points_at(P, u - scale)
    after = ring_points_at(P, u + scale) - P
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    dot = np.einsum("ij,ij->i", before, after)
    return np.arctan2(cross, dot)


def outline_features(ring: ArrayLike, *, options: FeatureOptions | None = None) -> OutlineFeatures:
    """Turning-angle extrema of a closed ring at a few scales, with a saliency score.

    Parameters
    ----------
    ring : (n, 2) array_like
        Closed ring (either orientation), last point not repeated.
    options : FeatureOptions, optional

    Returns
    -------
    OutlineFeatures

    Notes
    -----
    At each scale ``h`` (finest first) a vertex is an extremum when
    ``|turning|`` there is at least that of every vertex within arc ``h`` on
    either side, and exceeds both ``min_turning`` and
    ``circle_factor * 4 pi h``. An extremum within ``h`` of a feature found at
    a finer scale is that feature (its saliency becomes the larger of the
    two): a stroke end of two sharp corners stays two corners, wherever the
    outline has vertices. Ties on a plateau
    (e.g. several vertices of one sharp corner) are resolved by the
    separation step, which keeps the most salient vertex of each cluster
    (the first one on equal saliency). The result is invariant to rotation,
    translation and scale, and nearly so to resampling of the outline
    between its corners.

    Examples
    --------
    >>> f = outline_features([[0, 0], [2, 0], [2, 1], [0, 1]])
    >>> f.index.tolist(), np.round(f.saliency, 3).tolist()
    ([0, 1, 2, 3], [0.5, 0.5, 0.5, 0.5])
    """
    opts = options or FeatureOptions()
    P = _as_ring(ring)
    s, perimeter = ring_arc_positions(P)
    u = s / perimeter
    n = P.shape[0]
    saliency = np.zeros(n)
    turning = np.zeros(n)
    u3 = np.concatenate([u - 1.0, u, u + 1.0])
    for h in sorted(opts.scales):
        theta = turning_angles(P, h)
        a = np.abs(theta)
        local_max = a >= _window_max(np.tile(a, 3), u3, u, h) - 1e-12
        strong = a > max(opts.min_turning, opts.circle_factor * 4.0 * np.pi * h)
        found = np.flatnonzero(saliency > 0)
        for i in np.flatnonzero(local_max & strong):
            # a coarse extremum near a finer feature belongs to it (scale-space tracking)
            j = int(i)
            if found.size:
                d = np.abs(u[found] - u[i])
                d = np.minimum(d, 1.0 - d)
                if d.min() <= h + 1e-12:
                    j = int(found[np.argmin(d)])
            if a[i] / np.pi > saliency[j]:
                saliency[j] = a[i] / np.pi
                turning[j] = theta[i]
    keep = _separated(saliency, u, opts.min_separation)
    idx = np.flatnonzero(keep).astype(np.int64)
    return OutlineFeatures(index=idx, arc=u[idx], turning=turning[idx], saliency=saliency[idx])


def _window_max(a3: FloatArray, u3: FloatArray, u: FloatArray, h: float) -> FloatArray:
    """Largest ``a3`` over arc positions within ``h`` of each ``u`` (``a3``, ``u3``: three turns)."""
    lo = np.searchsorted(u3, u - h - 1e-12, side="left")
    hi = np.searchsorted(u3, u + h + 1e-12, side="right")
    padded = np.concatenate([a3, [-np.inf]])
    return np.maximum.reduceat(padded, np.ravel(np.column_stack([lo, hi])))[::2]


def _separated(saliency: FloatArray, u: FloatArray, sep: float) -> BoolArray:
    """Greedy non-maximum suppression: most salient first, drop those within arc ``sep``."""
    keep = np.zeros(saliency.shape[0], dtype=bool)
    blocked = np.zeros(saliency.shape[0], dtype=bool)
    order = np.lexsort((np.arange(saliency.shape[0]), -saliency))
    for i in order:
        if saliency[i] <= 0:
            break
        if blocked[i]:
            continue
        keep[i] = True
        d = np.abs(u - u[i])
        blocked |= np.minimum(d, 1.0 - d) <= sep + 1e-12
    return keep


def _as_ring(ring: ArrayLike) -> FloatArray:
    P = np.asarray(ring, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 3:
        raise ValueError(f"ring must have shape (n, 2) with n >= 3, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError("ring coordinates must be finite")
    return P
