"""Orientation of triangles in the plane."""

from __future__ import annotations

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray


def signed_areas_2d(uv: FloatArray, F: IntArray) -> FloatArray:
    """Signed areas of planar triangles (positive = counter-clockwise).

    Parameters
    ----------
    uv : (n, 2) float64
    F : (m, 3) int64

    Returns
    -------
    a : (m,) float64
    """
    p, q, r = uv[F[:, 0]], uv[F[:, 1]], uv[F[:, 2]]
    return 0.5 * ((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0]))


def flipped_triangles(uv: FloatArray, F: IntArray) -> BoolArray:
    """Triangles whose image is clockwise or degenerate (signed area ≤ 0).

    Parameters
    ----------
    uv : (n, 2) float64
        A parameterisation whose valid orientation is counter-clockwise.
    F : (m, 3) int64

    Returns
    -------
    flipped : (m,) bool
    """
    return np.asarray(signed_areas_2d(uv, F) <= 0.0)
