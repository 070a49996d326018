"""Discrete conformal factor of a parameterisation (section 2.3 of the face paper)."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .vertex_areas import vertex_areas


def conformal_factor(V: FloatArray, F: IntArray, uv: FloatArray) -> FloatArray:
    """One-ring area ratio λ_i = Area(N1(x_i)) / Area(φ(N1(x_i))).

    Parameters
    ----------
    V : (n, 3) float64
        Surface.
    F : (m, 3) int64
    uv : (n, 2) float64
        Its conformal parameterisation φ.

    Returns
    -------
    lam : (n,) float64
        Positive area ratios (3D over disk), so that ``ds² = λ |du|²``:
        λ is the factor of the metric, and ``λ_i A^uv_i`` is the 3D vertex
        area (the paper's eq. 1 writes λ² for the same quantity).

    Raises
    ------
    ValueError
        If a one-ring has zero area in the parameterisation.
    """
    A3 = vertex_areas(V, F)
    Auv = vertex_areas(uv, F)
    if np.any(Auv <= 0):
        bad = np.flatnonzero(Auv <= 0)[:8].tolist()
        raise ValueError(f"one-rings of vertices {bad} have zero area in the parameterisation")
    return A3 / Auv
