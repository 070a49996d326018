"""Point location in a planar triangle mesh, with barycentric coordinates."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray

#: Points are located in chunks of this many, to bound memory at k × m.
_CHUNK = 256


def locate_points(
    V: FloatArray, F: IntArray, P: FloatArray, *, atol: float = 1e-9
) -> tuple[IntArray, FloatArray]:
    """Find the triangle containing each point and its barycentric coordinates.

    Parameters
    ----------
    V : (n, 2) float64
        Vertex positions.
    F : (m, 3) int64
        Triangles (any orientation; degenerate triangles are skipped).
    P : (k, 2) float64
        Query points.
    atol : float, optional
        A point counts as inside a triangle when all its barycentric
        coordinates are ≥ ``-atol`` (relative: barycentric coordinates are
        dimensionless), so points on edges and vertices are found.

    Returns
    -------
    face : (k,) int64
        Containing triangle, or -1 when the point lies outside the mesh.
        Among several candidates (points on shared edges) the one with the
        largest smallest coordinate wins.
    bary : (k, 3) float64
        Barycentric coordinates in ``face`` (rows of NaN where ``face == -1``);
        ``bary @ V[F[face]]`` reproduces the point.

    Notes
    -----
    Brute force, O(k m) work in chunks; adequate for the few thousand
    triangles of 2D morphing meshes.

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> f, b = locate_points(V, np.array([[0, 1, 2]]), np.array([[0.25, 0.25], [2.0, 2.0]]))
    >>> f.tolist(), b[0].round(12).tolist()
    ([0, -1], [0.5, 0.25, 0.25])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    a = V[F[:, 0]]
    e1 = V[F[:, 1]] - a
    e2 = V[F[:, 2]] - a
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    good = np.abs(det) > 0
    inv = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)
    face = np.full(P.shape[0], -1, dtype=np.int64)
    bary = np.full((P.shape[0], 3), np.nan)
    for s in range(0, P.shape[0], _CHUNK):
        Q = P[s : s + _CHUNK]
        d = Q[:, None, :] - a[None, :, :]
        l1 = (d[..., 0] * e2[None, :, 1] - d[..., 1] * e2[None, :, 0]) * inv[None]
        l2 = (e1[None, :, 0] * d[..., 1] - e1[None, :, 1] * d[..., 0]) * inv[None]
        l0 = 1.0 - l1 - l2
        score = np.minimum(np.minimum(l0, l1), l2)
        score[:, ~good] = -np.inf
        best = np.argmax(score, axis=1)
        rows = np.arange(Q.shape[0])
        inside = score[rows, best] >= -atol
        idx = np.arange(s, s + Q.shape[0])[inside]
        face[idx] = best[inside]
        bary[idx, 0] = l0[rows, best][inside]
        bary[idx, 1] = l1[rows, best][inside]
        bary[idx, 2] = l2[rows, best][inside]
    return face, bary
