"""Linear vertex interpolation, the simplest morphing baseline."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray


def linear_interpolation(
    source_V: FloatArray, target_V: FloatArray, times: FloatArray
) -> FloatArray:
    """Linear vertex interpolation ``(1 − t) source + t target``, the simplest baseline.

    Parameters
    ----------
    source_V : (n, d) float64
        Source positions.
    target_V : (n, d) float64
        Target positions.
    times : (T,) float64
        Times.

    Returns
    -------
    frames : (T, n, d) float64
    """
    source_V = np.asarray(source_V, dtype=np.float64)
    target_V = np.asarray(target_V, dtype=np.float64)
    if target_V.shape != source_V.shape:
        raise ValueError(f"target_V has shape {target_V.shape}, expected {source_V.shape}")
    t = np.asarray(times, dtype=np.float64).reshape(-1, 1, 1)
    return np.asarray((1.0 - t) * source_V[None] + t * target_V[None], dtype=np.float64)
