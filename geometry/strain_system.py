"""The strain energy W of eq. (4), its gradient φ (eq. 9) and tangent K (eq. 10).

Yan, Hu and Martin (2004): the position field of a frame minimises
W = ½ ∫ |ε'(V) − ε^t|² dΩ; on linear triangles φ = Σ A Bᵀ (ε' − ε^t) with the
strain matrix B of eq. (8), and K = ∂φ/∂V. :class:`StrainSystem` also holds the
orientation barrier that the default solver adds to W.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .green_lagrange_strain import (
    deformation_gradient,
    shape_function_gradients,
    strain_from_gradient,
)


class StrainSystem:
    """Residual φ (eq. 9) and tangent K (eq. 10) of W (eq. 4) on a fixed mesh.

    The sparsity pattern of K over the free degrees of freedom is computed once.

    Parameters
    ----------
    rest : (n, 2) float64
        Rest positions (the source in the gauge frame).
    F : (m, 3) int64
        Triangles, counter-clockwise in ``rest``.
    fixed : (k,) int64
        Fixed degrees of freedom (``2 i`` is x of vertex i, ``2 i + 1`` its y).
    """

    def __init__(self, rest: FloatArray, F: IntArray, fixed: IntArray) -> None:
        self.F = F
        self.n = rest.shape[0]
        self.dN, self.area = shape_function_gradients(rest, F)
        m = F.shape[0]
        dof = np.zeros((m, 6), dtype=np.int64)
        dof[:, 0::2] = 2 * F
        dof[:, 1::2] = 2 * F + 1
        self.dof = dof
        free = np.ones(2 * self.n, dtype=bool)
        free[fixed] = False
        self.free = free
        new = np.full(2 * self.n, -1, dtype=np.int64)
        new[free] = np.arange(int(free.sum()))
        self.nf = int(free.sum())
        r = new[np.repeat(dof, 6, axis=1)].ravel()
        c = new[np.tile(dof, (1, 6))].ravel()
        keep = (r >= 0) & (c >= 0)
        self.keep = keep
        key = c[keep] * self.nf + r[keep]  # column-major order = CSC order
        ukey, self.pos = np.unique(key, return_inverse=True)
        self.indices = ukey % self.nf
        cols = ukey // self.nf
        self.indptr = np.searchsorted(cols, np.arange(self.nf + 1)).astype(np.int64)
        self.nnz = ukey.shape[0]

    def jacobians(self, X: FloatArray) -> FloatArray:
        """Deformation gradients J = ∂X/∂rest, (m, 2, 2), of positions X (n, 2)."""
        return deformation_gradient(self.dN, X, self.F)

    def det(self, X: FloatArray) -> FloatArray:
        """det J per triangle, (m,), of positions X (n, 2): the area ratio."""
        J = self.jacobians(X)
        return np.asarray(J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0], dtype=np.float64)

    def energy(self, X: FloatArray, eps_t: FloatArray) -> float:
        """W = ½ Σ A |ε'(X) − ε^t|² (eq. 4) of positions X (n, 2) and target strain (m, 3)."""
        r = strain_from_gradient(self.jacobians(X)) - eps_t
        return float(0.5 * np.sum(self.area * np.einsum("fc,fc->f", r, r)))

    def _strain_matrix(self, X: FloatArray, eps_t: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Strain matrix B of eq. (8), as (m, 3, 6), and the strain residual ε' − ε (m, 3)."""
        J = self.jacobians(X)
        gx, gy = J[:, :, 0], J[:, :, 1]
        r = strain_from_gradient(J) - eps_t
        dN = self.dN
        m = dN.shape[0]
        B = np.zeros((m, 3, 3, 2))  # (triangle, component, node, xy)
        B[:, 0] = dN[:, :, 0, None] * gx[:, None, :]
        B[:, 1] = dN[:, :, 1, None] * gy[:, None, :]
        B[:, 2] = dN[:, :, 0, None] * gy[:, None, :] + dN[:, :, 1, None] * gx[:, None, :]
        return B.reshape(m, 3, 6), r

    def _phi(self, B6: FloatArray, r: FloatArray) -> FloatArray:
        phi_f = self.area[:, None] * np.einsum("fci,fc->fi", B6, r)
        return np.asarray(
            np.bincount(self.dof.ravel(), phi_f.ravel(), minlength=2 * self.n)[self.free],
            dtype=np.float64,
        )

    def residual(self, X: FloatArray, eps_t: FloatArray) -> FloatArray:
        """φ of eq. (9) restricted to the free dofs, (2n − 3,)."""
        return self._phi(*self._strain_matrix(X, eps_t))

    def tangent(
        self,
        X: FloatArray,
        eps_t: FloatArray,
        extra: tuple[FloatArray, FloatArray] | None = None,
    ) -> tuple[FloatArray, sp.csc_array]:
        """φ and the tangent matrix K of eq. (10), both restricted to the free dofs.

        ``extra``: per-triangle gradient (m, 6) and Hessian (m, 6, 6) of a further
        energy term (area weighting included), added to φ and K.
        """
        B6, r = self._strain_matrix(X, eps_t)
        dN = self.dN
        m = dN.shape[0]
        # eq. (10): Bᵀ B + Gᵀ (S' − S) G, the second term block-diagonal in xy
        Kf = np.einsum("fci,fcj->fij", B6, B6)
        R = np.zeros((m, 2, 2))
        R[:, 0, 0], R[:, 1, 1] = r[:, 0], r[:, 1]
        R[:, 0, 1] = R[:, 1, 0] = r[:, 2]
        s = np.einsum("fka,fab,flb->fkl", dN, R, dN)
        Kf4 = Kf.reshape(m, 3, 2, 3, 2)
        Kf4[:, :, 0, :, 0] += s
        Kf4[:, :, 1, :, 1] += s
        Kf *= self.area[:, None, None]
        phi = self._phi(B6, r)
        if extra is not None:
            Kf += extra[1]
            phi = phi + self._assemble_vector(extra[0])
        data = np.bincount(self.pos, Kf.ravel()[self.keep], minlength=self.nnz)
        K = sp.csc_array((data, self.indices, self.indptr), shape=(self.nf, self.nf))
        return phi, K

    def _assemble_vector(self, g_f: FloatArray) -> FloatArray:
        """Sum per-triangle vectors (m, 6) into the free dofs."""
        return np.asarray(
            np.bincount(self.dof.ravel(), g_f.ravel(), minlength=2 * self.n)[self.free],
            dtype=np.float64,
        )

    def barrier(
        self, X: FloatArray, d_star: FloatArray, weight: float, s0: float, order: int
    ) -> tuple[float, FloatArray | None, FloatArray | None]:
        """The orientation barrier ``weight · Σ A ψ(det J / d*)``; for ``order`` ≥ 1 also
        its per-triangle gradient (m, 6) and Hessian (m, 6, 6) (None for ``order`` 0).

        ``ψ(s) = s/s0 − 1 − log(s/s0)`` below ``s0`` and 0 above: zero, with zero
        slope, while a triangle keeps at least the fraction ``s0`` of its prescribed
        area ratio ``d*``, and infinite as its area goes to 0 (inf if any is ≤ 0).
        """
        J = self.jacobians(X)
        d = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
        if np.any(d <= 0):
            return float("inf"), None, None
        sr = d / (s0 * d_star)
        on = sr < 1.0
        wA = weight * self.area
        energy = float(np.sum(wA[on] * (sr[on] - 1.0 - np.log(sr[on]))))
        if order == 0:  # the line search's energy evaluations: nothing else is needed
            return energy, None, None
        if not on.any():
            m = d.shape[0]
            return energy, np.zeros((m, 6)), np.zeros((m, 6, 6))
        dN = self.dN  # (m, 3 nodes, 2)
        # ∂d/∂x_{k,a} = Σ_b cof_ab dN_kb, cof = [[J11, −J10], [−J01, J00]]
        cof = np.stack(
            [np.stack([J[:, 1, 1], -J[:, 1, 0]], 1), np.stack([-J[:, 0, 1], J[:, 0, 0]], 1)], 1
        )
        grad_d = np.einsum("fab,fkb->fka", cof, dN).reshape(-1, 6)
        # ∂²d/∂x_{k,0}∂x_{l,1} = dN_k0 dN_l1 − dN_k1 dN_l0 (and its transpose)
        cross = dN[:, :, None, 0] * dN[:, None, :, 1] - dN[:, :, None, 1] * dN[:, None, :, 0]
        hess5 = np.zeros((d.shape[0], 3, 2, 3, 2))
        hess5[:, :, 0, :, 1] = cross
        hess5[:, :, 1, :, 0] = cross.transpose(0, 2, 1)
        hess_d = hess5.reshape(-1, 6, 6)
        c = s0 * d_star
        dpsi = np.where(on, 1.0 - 1.0 / sr, 0.0) / c  # ψ'(s) ds/dd
        d2psi = np.where(on, 1.0 / sr**2, 0.0) / c**2
        g = (wA * dpsi)[:, None] * grad_d
        H = (wA * d2psi)[:, None, None] * grad_d[:, :, None] * grad_d[:, None, :] + (wA * dpsi)[
            :, None, None
        ] * hess_d
        return energy, g, H
