"""Pairs of holes of two shapes, by position and size.

Each shape is put in the normal frame of its outer ring (centroid at the
origin, unit area); a hole pair costs the distance of the (rotated) centroids
plus a weight times ``|log|`` of the area ratio, and the assignment of least
total cost is the Hungarian algorithm's (:func:`scipy.optimize.linear_sum_assignment`).
Holes without a partner (more on one side, or too far) are left to
:func:`conformorph.geometry.hole_seeding.seed_missing_holes`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._typing import ComplexArray, FloatArray, IntArray
from .assignment import min_cost_assignment


@dataclass(frozen=True)
class HolePairingOptions:
    """Options of :func:`pair_holes`.

    Attributes
    ----------
    size_weight : float
        Weight of ``|log(area_s / area_t)|`` against the centroid distance
        (normal frame of the outer ring, unit area; default 0.5).
    max_cost : float
        Pairs dearer than this stay unpaired (default 1.0).
    """

    size_weight: float = 0.5
    max_cost: float = 1.0


@dataclass(frozen=True)
class HolePairs:
    """Pairs of holes of two shapes.

    Attributes
    ----------
    pairs : (p, 2) int64
        ``[source hole, target hole]`` (indices into the hole lists), by
        source hole.
    cost : (p,) float64
        Cost of each pair.
    unpaired_source, unpaired_target : (u,), (v,) int64
        Holes left without a partner.
    """

    pairs: IntArray
    cost: FloatArray
    unpaired_source: IntArray
    unpaired_target: IntArray


def pair_holes(
    source_holes: list[ArrayLike],
    target_holes: list[ArrayLike],
    *,
    source_outer: ArrayLike,
    target_outer: ArrayLike,
    rotation: float = 0.0,
    options: HolePairingOptions | None = None,
) -> HolePairs:
    """Pair the holes of two shapes by position and size (Hungarian algorithm).

    Parameters
    ----------
    source_holes, target_holes : list of (k, 2) array_like
        Hole rings of each shape (either orientation).
    source_outer, target_outer : (n, 2) array_like
        The outer rings, which set each shape's normal frame (centroid at 0,
        unit area).
    rotation : float, optional
        Rotation (radians) of the normalised source onto the normalised
        target, e.g. ``OutlineMatch.rotation`` from
        :func:`conformorph.geometry.outline_correspondence.match_outlines` (default 0).
    options : HolePairingOptions, optional

    Returns
    -------
    HolePairs

    Notes
    -----
    Cost of a pair: ``|R c_s - c_t| + size_weight * |log(A_s / A_t)|`` with
    ``c`` the hole centroid and ``A`` its area in the normal frame; the
    assignment minimises the total cost (:func:`scipy.optimize.linear_sum_assignment`),
    then pairs dearer than ``max_cost`` are dropped.

    Examples
    --------
    >>> sq = lambda x, y, h: [[x - h, y - h], [x - h, y + h], [x + h, y + h], [x + h, y - h]]
    >>> outer = [[0, 0], [10, 0], [10, 10], [0, 10]]
    >>> hp = pair_holes([sq(3, 3, 1), sq(7, 7, 1.5)], [sq(7, 7, 1), sq(3, 3, 1)],
    ...                 source_outer=outer, target_outer=outer)
    >>> hp.pairs.tolist()
    [[0, 1], [1, 0]]
    """
    opts = options or HolePairingOptions()
    fs = _frame(source_outer)
    ft = _frame(target_outer)
    cs, As = _hole_stats(source_holes, fs)
    ct, At = _hole_stats(target_holes, ft)
    if len(cs) == 0 or len(ct) == 0:
        return HolePairs(
            pairs=np.zeros((0, 2), dtype=np.int64),
            cost=np.zeros(0),
            unpaired_source=np.arange(len(cs), dtype=np.int64),
            unpaired_target=np.arange(len(ct), dtype=np.int64),
        )
    cs = cs * np.exp(1j * rotation)
    C = np.abs(cs[:, None] - ct[None, :]) + opts.size_weight * np.abs(
        np.log(As[:, None] / At[None, :])
    )
    r, c = min_cost_assignment(C)
    ok = C[r, c] <= opts.max_cost
    r, c = r[ok], c[ok]
    return HolePairs(
        pairs=np.column_stack([r, c]).astype(np.int64),
        cost=C[r, c],
        unpaired_source=np.setdiff1d(np.arange(len(cs)), r).astype(np.int64),
        unpaired_target=np.setdiff1d(np.arange(len(ct)), c).astype(np.int64),
    )


def ring_centroid_area(ring: ArrayLike) -> tuple[complex, float]:
    """Area centroid and signed area of a closed ring.

    Parameters
    ----------
    ring : (n, 2) array_like
        Closed ring, last point not repeated.

    Returns
    -------
    centroid : complex
        ``x + iy`` of the centroid.
    area : float
        Signed area (positive counter-clockwise).

    Raises
    ------
    ValueError
        Not a finite (n, 2) array with n >= 3, or zero area.

    Examples
    --------
    >>> ring_centroid_area([[0, 0], [2, 0], [2, 2], [0, 2]])
    ((1+1j), 4.0)
    """
    P = np.asarray(ring, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 3 or not np.all(np.isfinite(P)):
        raise ValueError(f"ring must be a finite (n, 2) array with n >= 3, got {P.shape}")
    m = P.mean(axis=0)  # about the mean: no cancellation far from the origin
    x, y = P[:, 0] - m[0], P[:, 1] - m[1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cross = x * yn - xn * y
    area = 0.5 * float(cross.sum())
    if not abs(area) > 1e-14 * float(np.sum(np.abs(cross))):
        raise ValueError("ring has zero area")
    cx = float(((x + xn) * cross).sum()) / (6 * area)
    cy = float(((y + yn) * cross).sum()) / (6 * area)
    return complex(cx + m[0], cy + m[1]), area


def _frame(outer: ArrayLike) -> tuple[complex, float]:
    c, area = ring_centroid_area(outer)
    return c, float(np.sqrt(abs(area)))


def _hole_stats(
    holes: list[ArrayLike], frame: tuple[complex, float]
) -> tuple[ComplexArray, FloatArray]:
    c0, scale = frame
    stats = [ring_centroid_area(h) for h in holes]
    cs = np.array([(c - c0) / scale for c, _ in stats], dtype=np.complex128)
    areas = np.array([abs(a) / scale**2 for _, a in stats], dtype=np.float64)
    return cs, areas
