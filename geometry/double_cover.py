"""Double covering of a disk-topology mesh into a closed genus-0 surface."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray
from .boundary_loop import boundary_loop
from .mesh_errors import NotTrianglesError


@dataclass(frozen=True)
class DoubleCover:
    """A disk mesh glued to a mirrored copy of itself along the boundary.

    Attributes
    ----------
    V : (N, 3) float64
        Vertices of the closed surface, ``N = 2 n − k``. Rows ``0 … n−1`` are
        the input vertices in the input order (the *first copy*); rows
        ``n … N−1`` are the second copies of the interior vertices, in
        increasing order of their input index.
    F : (2 m, 3) int64
        Triangles: rows ``0 … m−1`` are the input faces unchanged, rows
        ``m … 2m−1`` the second copy with reversed orientation, so the closed
        surface is consistently oriented (first copy's normals outward).
    source_vertex : (N,) int64
        Input vertex of every cover vertex (``source_vertex[:n] = arange(n)``).
    second_copy : (N,) bool
        True for the vertices of the second copy (``N − n`` of them).
    twin : (n,) int64
        Index in the cover of the second copy of every input vertex; equals
        the vertex itself for boundary vertices (they are shared).
    b : (k,) int64
        The boundary loop of the input (the seam of the cover).
    """

    V: FloatArray
    F: IntArray
    source_vertex: IntArray
    second_copy: BoolArray
    twin: IntArray
    b: IntArray

    @property
    def mirror(self) -> IntArray:
        """(N,) int64: the swap of the two copies, an involution fixing the seam."""
        n = self.twin.shape[0]
        out = np.concatenate([self.twin, self.source_vertex[n:]])
        return np.asarray(out, dtype=np.int64)


def double_cover(V: FloatArray, F: IntArray, b: IntArray | None = None) -> DoubleCover:
    """Glue two copies of a disk mesh along its boundary (Gu & Yau's double covering).

    Parameters
    ----------
    V : (n, 3) float64
        Vertices of a disk-topology mesh. Not modified.
    F : (m, 3) int64
        Triangles. Not modified.
    b : (k,) int64, optional
        The boundary loop; computed with :func:`conformorph.geometry.boundary_loop` when
        not given.

    Returns
    -------
    DoubleCover
        The closed surface (Euler characteristic 2 when the input is a disk)
        and the correspondence between cover vertices and input vertices.

    Notes
    -----
    The two sheets coincide in space; the cotangent Laplacian of the cover is
    still well defined (every triangle keeps its own angles), and at the seam
    every boundary edge gets one cotangent from each sheet. The second copy's
    faces are reversed so that the cover is orientable as a closed surface.

    References
    ----------
    X. Gu, Y. Wang, T. F. Chan, P. M. Thompson, S.-T. Yau, "Genus zero surface
    conformal mapping and its application to brain surface mapping", IEEE TMI
    23(8) (2004), doi:10.1109/TMI.2004.831226 (the double covering, their [17]
    in Yueh et al.).

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    >>> F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    >>> dc = double_cover(V, F)
    >>> dc.V.shape, dc.F.shape, dc.twin.tolist()
    ((6, 3), (8, 3), [5, 1, 2, 3, 4])
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise NotTrianglesError(f"V must have shape (n, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or not np.issubdtype(F.dtype, np.integer):
        raise NotTrianglesError(f"F must be an integer array of shape (m, 3), got {F.shape}")
    F = F.astype(np.int64)
    n = V.shape[0]
    if b is None:
        b = boundary_loop(F, V)
    b = np.asarray(b, dtype=np.int64)
    on_boundary = np.zeros(n, dtype=bool)
    on_boundary[b] = True
    interior = np.flatnonzero(~on_boundary)
    twin = np.arange(n, dtype=np.int64)
    twin[interior] = n + np.arange(interior.size, dtype=np.int64)
    Vc = np.concatenate([V, V[interior]], axis=0)
    F2 = twin[F][:, [0, 2, 1]]
    Fc = np.concatenate([F, F2], axis=0)
    source = np.concatenate([np.arange(n, dtype=np.int64), interior])
    second = np.zeros(Vc.shape[0], dtype=bool)
    second[n:] = True
    return DoubleCover(V=Vc, F=Fc, source_vertex=source, second_copy=second, twin=twin, b=b)
