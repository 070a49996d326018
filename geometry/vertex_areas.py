"""Barycentric vertex areas: the lumped mass of a triangle mesh (3D or on the plane)."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .validate_mesh import triangle_areas


def vertex_areas(V: FloatArray, F: IntArray) -> FloatArray:
    """Barycentric vertex areas (a third of each incident triangle).

    Parameters
    ----------
    V : (n, d) float64
        Vertex positions, ``d`` = 2 (a planar map) or 3.
    F : (m, 3) int64
        Triangles.

    Returns
    -------
    A : (n,) float64
        ``A_i = Σ_{t ∋ i} |t| / 3``; the entries sum to the total area.

    Examples
    --------
    >>> import numpy as np
    >>> vertex_areas(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.array([[0, 1, 2]]))
    array([0.16666667, 0.16666667, 0.16666667])
    """
    if V.shape[1] == 2:
        p, q, r = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        a = 0.5 * np.abs(
            (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])
        )
    else:
        a = triangle_areas(V, F)
    areas = np.bincount(F.reshape(-1), weights=np.repeat(a / 3.0, 3), minlength=V.shape[0])
    return np.asarray(areas, dtype=np.float64)
