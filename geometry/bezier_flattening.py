"""Bézier curves flattened to a distance tolerance (Wang's bound), not to a fixed count.

A polynomial curve of degree d with control points P_0 … P_d, cut into n equal
parameter steps, stays within

    d (d - 1) / 8 · max_i |P_i - 2 P_{i+1} + P_{i+2}| / n²

of its chord polygon (Wang 1984; e.g. Sederberg, *Computer Aided Geometric
Design*, §10.6). :func:`bezier_segment_count` takes the least n that keeps this
bound under ``tol``; :func:`bezier_points` evaluates the curve there.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ._typing import FloatArray

#: Most segments one curve is cut into, however tight the tolerance (a bound on
#: the work a hostile control polygon can ask for).
MAX_CURVE_SEGMENTS = 256


def bezier_segment_count(ctrl: ArrayLike, tol: float) -> int:
    """The fewest equal parameter steps that keep a Bézier curve within ``tol`` of its chords.

    Parameters
    ----------
    ctrl : (d + 1, 2) array_like
        Control points, degree d ≥ 1 (a line needs one segment).
    tol : float
        Largest distance between the curve and its polygon (> 0).

    Returns
    -------
    int
        n in [1, ``MAX_CURVE_SEGMENTS``] with d (d - 1) / 8 · M / n² ≤ tol, M the
        largest second difference of the control points (Wang's bound).

    Raises
    ------
    ValueError
        ``ctrl`` not (k, 2) with k ≥ 2, not finite, or ``tol`` not positive.

    Examples
    --------
    >>> bezier_segment_count([[0, 0], [1, 2], [2, 0]], 0.01)
    10
    """
    P = np.asarray(ctrl, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 2:
        raise ValueError(f"ctrl must have shape (k, 2) with k >= 2, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError("ctrl must be finite")
    if not tol > 0:
        raise ValueError(f"tol must be positive, got {tol}")
    d = P.shape[0] - 1
    if d < 2:
        return 1
    M = float(np.max(np.linalg.norm(P[:-2] - 2 * P[1:-1] + P[2:], axis=1)))
    n = math.ceil(math.sqrt(d * (d - 1) / 8.0 * M / tol)) if M > 0 else 1
    return int(min(max(n, 1), MAX_CURVE_SEGMENTS))


def bezier_points(ctrl: ArrayLike, n: int) -> FloatArray:
    """The n points after the start of a Bézier curve, at parameters k / n, k = 1 … n.

    Parameters
    ----------
    ctrl : (d + 1, 2) array_like
        Control points (any degree d ≥ 1), evaluated in Bernstein form.
    n : int
        Number of steps (≥ 1).

    Returns
    -------
    (n, 2) float64
        The last row is the end point ``ctrl[-1]`` exactly.

    Examples
    --------
    >>> bezier_points([[0, 0], [1, 2], [2, 0]], 2).tolist()
    [[1.0, 1.0], [2.0, 0.0]]
    """
    P = np.asarray(ctrl, dtype=np.float64)
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    d = P.shape[0] - 1
    t = (np.arange(1, n + 1) / n)[:, None]
    out = np.zeros((n, 2))
    for i in range(d + 1):
        out += math.comb(d, i) * (1 - t) ** (d - i) * t**i * P[i]
    out[-1] = P[-1]
    return out
