"""Piecewise cubic spline homotopy through key-frame data (section 4 of the face paper).

:math:`\\mathscr{S}[x_0, \\dots, x_N](t)`: for every vertex q of the consistent
mesh, one cubic spline in t through its key values — disk positions
:math:`[\\bar f]_i(q)`, mean curvature, conformal factor, colours — all
vertices and components at once.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from scipy.interpolate import CubicSpline

from ._typing import FloatArray

BoundaryCondition = Literal["natural", "not-a-knot", "clamped"]


class SplineHomotopy:
    """Cubic spline in time through key values, evaluated for all vertices at once.

    Parameters
    ----------
    times : (N + 1,) float64
        Strictly increasing key times :math:`t_0 < \\dots < t_N`, N ≥ 1.
    values : (N + 1, ...) float64
        Key values; ``values[i]`` is the data at ``times[i]`` (any trailing
        shape, e.g. (n,) for H or (n, 2) for disk positions).
    bc_type : {"natural", "not-a-knot", "clamped"}, default "natural"
        End conditions: zero second derivative (natural, the default), the
        not-a-knot condition, or zero first derivative (clamped). With two
        keys every choice except "clamped" is the straight line.

    Notes
    -----
    Outside :math:`[t_0, t_N]` the end cubic pieces are continued
    (extrapolation, Table 4 of the paper). The spline is C² and reproduces
    the keys exactly; a path linear in t is reproduced exactly by the
    natural and not-a-knot conditions.
    """

    def __init__(
        self, times: FloatArray, values: FloatArray, *, bc_type: BoundaryCondition = "natural"
    ) -> None:
        t = np.asarray(times, dtype=np.float64)
        y = np.asarray(values, dtype=np.float64)
        if t.ndim != 1 or t.size < 2:
            raise ValueError(f"need at least 2 key times as a 1-D array, got shape {t.shape}")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise ValueError(f"key times must be finite and strictly increasing, got {t.tolist()}")
        if y.shape[:1] != t.shape:
            raise ValueError(f"values must have shape ({t.size}, ...), got {y.shape}")
        if not np.all(np.isfinite(y)):
            raise ValueError("key values must be finite")
        if bc_type not in ("natural", "not-a-knot", "clamped"):
            raise ValueError(f"unknown bc_type {bc_type!r}")
        self.times = t.copy()
        self.shape = y.shape[1:]
        flat = y.reshape(t.size, -1)
        if t.size == 2 and bc_type == "not-a-knot":
            bc_type = "natural"  # scipy needs ≥ 3 points for not-a-knot; both give the line
        self._spline = CubicSpline(t, flat, axis=0, bc_type=bc_type, extrapolate=True)

    def __call__(self, t: float | FloatArray, nu: int = 0) -> FloatArray:
        """Evaluate the homotopy (or its ``nu``-th time derivative).

        Parameters
        ----------
        t : float or (T,) float64
            Evaluation times (any real values; outside the keys: extrapolation).
        nu : int, default 0
            Derivative order.

        Returns
        -------
        (...) float64 for a scalar t, (T, ...) float64 for an array.
        """
        ta = np.asarray(t, dtype=np.float64)
        if not np.all(np.isfinite(ta)):
            raise ValueError("evaluation times must be finite")
        out = self._spline(ta.reshape(-1), nu)
        out = out.reshape((ta.size,) + self.shape)
        return np.asarray(out[0] if ta.ndim == 0 else out)


def spline_homotopy(
    times: FloatArray,
    values: FloatArray,
    t_eval: float | FloatArray,
    *,
    bc_type: BoundaryCondition = "natural",
) -> FloatArray:
    """One-shot form of :class:`SplineHomotopy`.

    Parameters
    ----------
    times : (N + 1,) float64
        Strictly increasing key times.
    values : (N + 1, ...) float64
        Key values.
    t_eval : float or (T,) float64
        Evaluation times.
    bc_type : {"natural", "not-a-knot", "clamped"}, default "natural"

    Returns
    -------
    (...) or (T, ...) float64

    Examples
    --------
    >>> import numpy as np
    >>> spline_homotopy(np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 2.0]), [0.5, 3.0]).tolist()
    [0.5, 3.0]
    """
    return SplineHomotopy(times, values, bc_type=bc_type)(np.asarray(t_eval, dtype=np.float64))
