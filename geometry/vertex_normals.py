"""Area-weighted vertex normals."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray


def _face_normal_vectors(V: FloatArray, F: IntArray) -> FloatArray:
    """(m, 3) ``(v1 - v0) × (v2 - v0)`` per triangle, by coordinate columns: the same
    values as ``np.cross`` on gathered rows, about 4x faster on large meshes (gathers of
    contiguous columns, no (m, 3) temporaries)."""
    x, y, z = np.ascontiguousarray(np.asarray(V, dtype=np.float64).T)
    i, j, k = np.ascontiguousarray(np.asarray(F, dtype=np.int64).T)
    ax, ay, az = x[j] - x[i], y[j] - y[i], z[j] - z[i]
    bx, by, bz = x[k] - x[i], y[k] - y[i], z[k] - z[i]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=1)


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
    fn = _face_normal_vectors(V, F)  # 2 × area × unit normal
    # the corners' sums by bincount (one pass per coordinate): the sums ``np.add.at``
    # makes, about 8x faster (a 270k-vertex morph's 31 frames spent 14.5 s in add.at)
    corners = np.asarray(F, dtype=np.int64).ravel()
    per_corner = np.repeat(fn, 3, axis=0)
    N = np.stack(
        [np.bincount(corners, weights=per_corner[:, c], minlength=V.shape[0]) for c in range(3)],
        axis=1,
    )
    length = np.linalg.norm(N, axis=1, keepdims=True)
    floor = rtol * np.linalg.norm(fn, axis=1).max(initial=0.0) if rtol > 0 else 0.0
    return np.divide(N, length, out=np.zeros_like(N), where=length > floor)
