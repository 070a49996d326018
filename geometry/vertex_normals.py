"""Area-weighted vertex normals."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray


def vertex_normals(V: FloatArray, F: IntArray, *, rtol: float = 0.0) -> FloatArray:
    """Unit vertex normals, the area-weighted mean of incident face normals.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        Consistently oriented triangles.
    rtol : float, optional
        A vertex whose summed normal is no longer than ``rtol`` times the
        largest face's ``|(v1 - v0) × (v2 - v0)|`` (twice its area) counts as
        cancelling; the default 0 counts exactly zero sums only.

    Returns
    -------
    N : (n, 3) float64
        Unit normals (right-hand rule on the face order); a vertex whose
        incident normals cancel gets (0, 0, 0).
    """
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])  # 2 × area × unit normal
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    length = np.linalg.norm(N, axis=1, keepdims=True)
    floor = rtol * np.linalg.norm(fn, axis=1).max(initial=0.0) if rtol > 0 else 0.0
    return np.divide(N, length, out=np.zeros_like(N), where=length > floor)
