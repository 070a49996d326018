"""Cotangent Laplacian and vertex areas of a triangle mesh given by its edge lengths (a metric).

The face paper's Laplace–Beltrami operator :math:`\\Delta_s = \\lambda^{-1}\\Delta_{uv}`
is that of the metric :math:`\\lambda |du|^2`; a discrete metric is one length
per edge, and its cotangent Laplacian follows from the lengths alone (law of
cosines), with the same sign convention as :func:`conformorph.geometry.cotangent_laplacian`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .mesh_edges import MeshEdges, mesh_edges


def edge_lengths(V: FloatArray, F: IntArray, E: MeshEdges | None = None) -> FloatArray:
    """Length of every unique edge.

    Parameters
    ----------
    V : (n, d) float64
    F : (m, 3) int64
    E : MeshEdges, optional
        ``mesh_edges(F)``.

    Returns
    -------
    (e,) float64
        In the order of ``mesh_edges(F).edges``.
    """
    E = mesh_edges(F) if E is None else E
    return np.asarray(np.linalg.norm(V[E.edges[:, 0]] - V[E.edges[:, 1]], axis=1))


def intrinsic_cotangents(
    F: IntArray, lengths: FloatArray, E: MeshEdges | None = None
) -> tuple[FloatArray, FloatArray, int]:
    """Corner cotangents and triangle areas from edge lengths.

    Parameters
    ----------
    F : (m, 3) int64
    lengths : (e,) float64
        Positive length of every edge of ``mesh_edges(F)``.
    E : MeshEdges, optional

    Returns
    -------
    cot : (m, 3) float64
        ``cot[f, k]``: cotangent of the angle at corner k (opposite edge
        (F[f, k+1], F[f, k+2])).
    area : (m,) float64
    n_clamped : int
        Triangles made valid by shortening their longest edge (see
        :func:`intrinsic_cotangent_laplacian`).
    """
    F = np.asarray(F, dtype=np.int64)
    E = mesh_edges(F) if E is None else E
    ell = np.asarray(lengths, dtype=np.float64)
    if ell.shape != (E.edges.shape[0],):
        raise ValueError(f"lengths must have shape ({E.edges.shape[0]},), got {ell.shape}")
    if not np.all(np.isfinite(ell)) or np.any(ell <= 0):
        raise ValueError("edge lengths must be positive and finite")
    he = E.halfedge_edge  # (m, 3): edge (F[:, k], F[:, k+1])
    lt = np.stack([ell[he[:, 1]], ell[he[:, 2]], ell[he[:, 0]]], axis=1)
    s = lt.sum(axis=1, keepdims=True)
    lmax = lt.max(axis=1, keepdims=True)
    bad = (2 * lmax >= s * (1 - 1e-9)).ravel()
    if bad.any():
        other = s[bad] - lmax[bad]
        k = np.argmax(lt[bad], axis=1)
        lt[np.flatnonzero(bad), k] = (1 - 1e-6) * other[:, 0]
    a, b, c = lt[:, 0], lt[:, 1], lt[:, 2]
    x = np.sort(lt, axis=1)[:, ::-1]
    p, q, r = x[:, 0], x[:, 1], x[:, 2]
    area = 0.25 * np.sqrt(
        np.clip((p + (q + r)) * (r - (p - q)) * (r + (p - q)) * (p + (q - r)), 0.0, None)
    )
    area = np.maximum(area, 1e-300)
    cot = np.stack([(b**2 + c**2 - a**2), (c**2 + a**2 - b**2), (a**2 + b**2 - c**2)], axis=1) / (
        4.0 * area[:, None]
    )
    return cot, area, int(bad.sum())


def intrinsic_cotangent_laplacian(
    F: IntArray, lengths: FloatArray, E: MeshEdges | None = None
) -> tuple[sp.csr_array, FloatArray, int]:
    """Cotangent Laplacian (PSD convention) and barycentric vertex areas from edge lengths.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles.
    lengths : (e,) float64
        Positive length of every edge of ``mesh_edges(F)``.
    E : MeshEdges, optional
        ``mesh_edges(F)``, reused if given.

    Returns
    -------
    L : (n, n) csr_array
        ``L[i, j] = -(cot α_ij + cot β_ij)/2``, ``L @ 1 = 0``; equal to
        :func:`conformorph.geometry.cotangent_laplacian` of any embedding with these lengths.
    A : (n,) float64
        Barycentric vertex areas (Heron).
    n_clamped : int
        Triangles whose lengths violated the triangle inequality and were
        made (just) valid by shortening their longest edge in that triangle
        (reported, never silent; 0 for lengths of a real embedding).

    Examples
    --------
    >>> import numpy as np
    >>> F = np.array([[0, 1, 2]])
    >>> L, A, bad = intrinsic_cotangent_laplacian(F, np.array([1.0, 1.0, np.sqrt(2.0)]))
    >>> L.toarray().round(6).tolist(), bad
    ([[1.0, -0.5, -0.5], [-0.5, 0.5, 0.0], [-0.5, 0.0, 0.5]], 0)
    """
    F = np.asarray(F, dtype=np.int64)
    cot, area, n_bad = intrinsic_cotangents(F, lengths, E)
    n = int(F.max()) + 1
    rows, cols, vals = [], [], []
    for k in range(3):
        i, j = F[:, (k + 1) % 3], F[:, (k + 2) % 3]
        w = 0.5 * cot[:, k]
        rows += [i, j, i, j]
        cols += [j, i, i, j]
        vals += [-w, -w, w, w]
    L = sp.csr_array(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
    )
    A = np.bincount(F.ravel(), weights=np.repeat(area / 3.0, 3), minlength=n).astype(np.float64)
    return L, A, n_bad


class IntrinsicLaplacianPattern:
    """Fixed sparsity pattern of the interior/boundary blocks, for many metrics on one mesh.

    Parameters
    ----------
    F : (m, 3) int64
    b : (k,) int64
        Boundary (Dirichlet) vertices.

    Notes
    -----
    The triplet → CSR mapping is computed once; each :meth:`blocks` call only
    sums the new values into place (``np.bincount``), which is what makes
    per-frame assembly cheap.
    """

    def __init__(self, F: IntArray, b: IntArray) -> None:
        self.F = np.asarray(F, dtype=np.int64)
        self.E = mesh_edges(self.F)
        n = int(self.F.max()) + 1
        self.n = n
        bmask = np.zeros(n, dtype=bool)
        bmask[np.asarray(b, dtype=np.int64)] = True
        self.interior = np.flatnonzero(~bmask)
        self.b = np.asarray(b, dtype=np.int64)
        new = np.full(n, -1, dtype=np.int64)
        new[self.interior] = np.arange(self.interior.size)
        newb = np.full(n, -1, dtype=np.int64)
        newb[self.b] = np.arange(self.b.size)
        rows, cols = [], []
        for k in range(3):
            i, j = self.F[:, (k + 1) % 3], self.F[:, (k + 2) % 3]
            rows += [i, j, i, j]
            cols += [j, i, i, j]
        r = np.concatenate(rows)
        c = np.concatenate(cols)
        ii = ~bmask[r] & ~bmask[c]
        ib = ~bmask[r] & bmask[c]
        self._sel_II, self._sel_IB = ii, ib
        nI, nB = self.interior.size, self.b.size
        self._II = self._prepare(new[r[ii]], new[c[ii]], nI, nI)
        self._IB = self._prepare(new[r[ib]], newb[c[ib]], nI, nB)

    @staticmethod
    def _prepare(
        r: IntArray, c: IntArray, nr: int, nc: int
    ) -> tuple[IntArray, IntArray, IntArray, tuple[int, int]]:
        keys = r * nc + c
        uniq, inv = np.unique(keys, return_inverse=True)
        rr, cc = np.divmod(uniq, nc)
        indptr = np.r_[0, np.cumsum(np.bincount(rr, minlength=nr))].astype(np.int64)
        return inv.astype(np.int64), cc.astype(np.int64), indptr, (nr, nc)

    @staticmethod
    def _build(
        spec: tuple[IntArray, IntArray, IntArray, tuple[int, int]], vals: FloatArray
    ) -> sp.csr_array:
        inv, cc, indptr, shape = spec
        data = np.bincount(inv, weights=vals, minlength=cc.size)
        return sp.csr_array((data, cc, indptr), shape=shape)

    def blocks(self, lengths: FloatArray) -> tuple[sp.csr_array, sp.csr_array, FloatArray, int]:
        """``L_II``, ``L_IB``, vertex areas (n,) and the clamp count for one metric."""
        cot, area, n_bad = intrinsic_cotangents(self.F, lengths, self.E)
        vals = []
        for k in range(3):
            w = 0.5 * cot[:, k]
            vals += [-w, -w, w, w]
        v = np.concatenate(vals)
        A = np.bincount(self.F.ravel(), weights=np.repeat(area / 3.0, 3), minlength=self.n)
        return (
            self._build(self._II, v[self._sel_II]),
            self._build(self._IB, v[self._sel_IB]),
            A.astype(np.float64),
            n_bad,
        )
