"""Winding numbers of points with respect to a set of closed rings (SVG's fill rules)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from ._typing import FloatArray, IntArray

#: Point × edge entries handled per vectorised block (bounded memory).
_BLOCK = 1 << 18


def winding_numbers(rings: Sequence[ArrayLike], P: ArrayLike) -> IntArray:
    """How many times the rings, together, wind around each point.

    Parameters
    ----------
    rings : sequence of (k_i, 2) array_like
        Closed polygons (last point not repeated), any orientation: each
        counter-clockwise turn counts +1, each clockwise turn -1 (y up).
    P : (p, 2) array_like
        Query points, not on any ring.

    Returns
    -------
    w : (p,) int64
        The winding number (the crossing-number form: an upward edge crossing
        the ray to the right of the point counts +1, a downward one -1). SVG's
        ``fill-rule="nonzero"`` paints where ``w != 0``, ``"evenodd"`` where
        ``w`` is odd (SVG 2, §13.4.2; in SVG's y-down frame the signs flip,
        which changes neither rule).

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2]])
    >>> winding_numbers([sq, sq + 0.5], [[0.25, 0.25], [1, 1], [5, 5]]).tolist()
    [1, 2, 0]
    """
    Q = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    w = np.zeros(Q.shape[0], dtype=np.int64)
    for ring in rings:
        a = np.asarray(ring, dtype=np.float64)
        b = np.roll(a, -1, axis=0)
        step = max(1, _BLOCK // max(1, a.shape[0]))
        for s in range(0, Q.shape[0], step):
            x, y = Q[s : s + step, 0][:, None], Q[s : s + step, 1][:, None]
            up = (a[None, :, 1] <= y) & (b[None, :, 1] > y)
            down = (a[None, :, 1] > y) & (b[None, :, 1] <= y)
            # which side of the edge a -> b the point lies on (> 0: left)
            side = (b[None, :, 0] - a[None, :, 0]) * (y - a[None, :, 1]) - (x - a[None, :, 0]) * (
                b[None, :, 1] - a[None, :, 1]
            )
            w[s : s + step] += np.sum(up & (side > 0), axis=1) - np.sum(down & (side < 0), axis=1)
    return w


def ring_winding_signs(rings: Sequence[FloatArray]) -> IntArray:
    """+1 for a counter-clockwise ring, -1 for a clockwise one, 0 for zero area (y up).

    Parameters
    ----------
    rings : sequence of (k_i, 2) float64

    Returns
    -------
    (r,) int64
    """
    out = []
    for r in rings:
        x, y = r[:, 0], r[:, 1]
        area = 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
        out.append(int(np.sign(area)))
    return np.asarray(out, dtype=np.int64)
