"""Even pacing of a morph: the times at which a sampled path moves by equal steps.

A strain-field morph is a path of shapes V(t), t ∈ [0, 1]. Eq. (3) of the
strain paper makes the angle between lines first along x and y change
linearly in t, so a large shear γⁿ grows like tan(t arctan γⁿ), which is
steep near t = 1: the letters S → U move 0.74 of the target's diagonal in
the last of 60 equal time steps (``max_step_ratio`` 18.6). Playing the same
path at other parameter values, chosen so that the largest vertex move is the
same between any two consecutive frames, removes the snap and keeps every
frame a solution of eq. (9) for its strain: the re-timing is monotone, so
strains that change monotonically in t still do.
"""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray


def path_steps(frames: FloatArray) -> FloatArray:
    """Largest vertex move between consecutive frames.

    Parameters
    ----------
    frames : (T, n, d) float64

    Returns
    -------
    steps : (T - 1,) float64
        ``max_v |frames[j + 1, v] − frames[j, v]|``.
    """
    X = np.asarray(frames, dtype=np.float64)
    if X.ndim != 3 or X.shape[0] < 1:
        raise ValueError(f"frames must be (T, n, d), got {X.shape}")
    return np.asarray(np.linalg.norm(np.diff(X, axis=0), axis=2).max(axis=1), dtype=np.float64)


def even_pace_times(times: FloatArray, frames: FloatArray, count: int) -> FloatArray:
    """Parameter values at which a sampled path moves by equal steps.

    Parameters
    ----------
    times : (T,) float64
        Strictly increasing parameter values of the samples (T ≥ 2).
    frames : (T, n, d) float64
        The path at ``times``.
    count : int
        Frames wanted (≥ 2).

    Returns
    -------
    tau : (count,) float64
        From ``times[0]`` to ``times[-1]``, non-decreasing: the inverse of the
        path length ``s(t)`` (sum of :func:`path_steps`, linear between
        samples) at ``count`` equally spaced lengths. A path that does not move
        gets equally spaced times.

    Notes
    -----
    The length is measured by the largest vertex move, the quantity of
    :attr:`conformorph.geometry.morph_metrics_2d.MorphMetrics2D.max_step_ratio`, so the
    re-timed path has that ratio near 1 as the samples resolve the path
    (it is exact for a path that moves uniformly between samples).

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> path = (t**2)[:, None, None] * np.ones((1, 1, 2))  # one point, x = y = t²
    >>> np.round(even_pace_times(t, path, 3), 3)  # half the length at t = √½
    array([0.   , 0.707, 1.   ])
    """
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if t.size < 2 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise ValueError("times must be at least two finite, strictly increasing values")
    steps = path_steps(frames)
    if steps.size != t.size - 1:
        raise ValueError(f"frames has {steps.size + 1} samples, times {t.size}")
    if count < 2:
        raise ValueError(f"count must be at least 2, got {count}")
    s = np.r_[0.0, np.cumsum(steps)]
    if s[-1] <= 0:
        return np.linspace(t[0], t[-1], count)
    tau = np.interp(np.linspace(0.0, s[-1], count), s, t)
    tau[0], tau[-1] = t[0], t[-1]
    return np.asarray(tau, dtype=np.float64)
