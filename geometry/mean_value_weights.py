"""Floater's mean-value weights: positive edge weights for bijective maps."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .angle_distortion import corner_angles


def mean_value_laplacian(V: FloatArray, F: IntArray) -> sp.csr_array:
    """Row-wise mean-value Laplacian (not symmetric).

    Parameters
    ----------
    V : (n, d) float64
        Positions, d = 2 or 3.
    F : (m, 3) int64

    Returns
    -------
    W : (n, n) csr_array
        ``W[i, j] = -(tan(α/2) + tan(β/2)) / |x_i − x_j|`` for the two corner
        angles α, β at i next to edge ij, and ``W[i, i] = -Σ_j W[i, j]``.
        Every off-diagonal weight is negative (i.e. every edge weight is
        positive), so by Floater's theorem a map whose interior rows satisfy
        ``W u = 0`` and whose boundary is a strictly convex polygon is a
        bijection onto that polygon.

    References
    ----------
    M. S. Floater, "Mean value coordinates", Computer Aided Geometric
    Design 20 (2003) 19–27, doi:10.1016/S0167-8396(03)00002-5.
    """
    n = V.shape[0]
    ang = corner_angles(V, F)
    rows, cols, vals = [], [], []
    for k in range(3):
        i = F[:, k]
        t = np.tan(0.5 * ang[:, k])
        for j in (F[:, (k + 1) % 3], F[:, (k + 2) % 3]):
            w = t / np.linalg.norm(V[i] - V[j], axis=1)
            rows += [i, i]
            cols += [j, i]
            vals += [-w, w]
    W = sp.coo_array(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
    ).tocsr()
    W.sum_duplicates()
    return W
