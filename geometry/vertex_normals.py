"""Area-weighted vertex normals, of one mesh or of many positions of one connectivity."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray

#: triangles per block when forming face normals: the block's temporaries (a few MB)
#: stay in cache and are reused, where whole-mesh temporaries of a 1M-vertex scan
#: (50 MB each) are fresh pages on every call
_BLOCK = 1 << 16


class VertexNormals:
    """Vertex normals of one connectivity ``F`` at any positions (the mesh's frames).

    Each call forms the face normals block by block and adds each to its three corners,
    corner 0 of every face first, as ``np.add.at`` over ``F[:, k]`` for k = 0, 1, 2 would
    (the same sums in the same order, so the same bits), by one ``bincount`` per
    coordinate.

    Parameters
    ----------
    F : (m, 3) int64
        Consistently oriented triangles.
    n : int
        Vertex count.
    """

    def __init__(self, F: IntArray, n: int) -> None:
        self.F = np.asarray(F, dtype=np.int64)
        if self.F.ndim != 2 or self.F.shape[1] != 3:
            raise ValueError(f"F must be (m, 3), got {self.F.shape}")
        self.n = int(n)
        if self.F.size and (self.F.min() < 0 or self.F.max() >= self.n):
            raise ValueError(f"F indexes vertices outside 0..{self.n - 1}")
        self._corners = self.F.T.ravel()  # corner 0 of every face, then 1, then 2
        m = self.F.shape[0]
        self._columns = [self._corners[k * m : (k + 1) * m] for k in range(3)]  # F[:, k]

    def face_normals(self, V: FloatArray) -> FloatArray:
        """(m, 3) ``(v1 - v0) × (v2 - v0)``: twice each triangle's area times its unit normal."""
        m = self.F.shape[0]
        fn = np.zeros((m, 3))
        for s in range(0, m, _BLOCK):
            v0, v1, v2 = (np.take(V, c[s : s + _BLOCK], axis=0) for c in self._columns)
            fn[s : s + _BLOCK] = np.cross(v1 - v0, v2 - v0)
        return fn

    def __call__(self, V: FloatArray, *, rtol: float = 0.0) -> FloatArray:
        """Unit vertex normals at positions ``V`` (n, 3); see :func:`vertex_normals`."""
        V = np.asarray(V, dtype=np.float64)
        if V.shape != (self.n, 3):
            raise ValueError(f"V must be ({self.n}, 3), got {V.shape}")
        fn = self.face_normals(V)
        N = np.stack(
            [np.bincount(self._corners, np.tile(fn[:, j], 3), minlength=self.n) for j in range(3)],
            axis=1,
        )
        length = np.linalg.norm(N, axis=1, keepdims=True)
        floor = rtol * np.linalg.norm(fn, axis=1).max(initial=0.0) if rtol > 0 else 0.0
        return np.divide(N, length, out=np.zeros_like(N), where=length > floor)


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

    See Also
    --------
    VertexNormals : the same for many positions of one connectivity (a morph's frames).
    """
    V = np.asarray(V, dtype=np.float64)
    return VertexNormals(F, V.shape[0])(V, rtol=rtol)
