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
from .green_lagrange_strain import shape_function_gradients
from .sparse_factor import Factorization, SymmetricRefactorization


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
        self.FT = np.ascontiguousarray(F.T)  # (3, m)
        self.dNx = np.ascontiguousarray(self.dN[:, :, 0].T)  # (3, m): ∂N_k/∂x
        self.dNy = np.ascontiguousarray(self.dN[:, :, 1].T)
        self._hess_d: FloatArray | None = None
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
        # per-triangle blocks are laid out (6, 6, m): entry [i, j, f] couples dofs i, j of f
        self.dofT = np.ascontiguousarray(dof.T)
        r = new[np.broadcast_to(self.dofT[:, None, :], (6, 6, m))].ravel()
        c = new[np.broadcast_to(self.dofT[None, :, :], (6, 6, m))].ravel()
        keep = (r >= 0) & (c >= 0)
        self.keep = keep
        key = c[keep] * self.nf + r[keep]  # column-major order = CSC order
        ukey, self.pos = np.unique(key, return_inverse=True)
        self.indices = ukey % self.nf
        cols = ukey // self.nf
        self.indptr = np.searchsorted(cols, np.arange(self.nf + 1)).astype(np.int64)
        self.nnz = ukey.shape[0]
        # upper triangle of K (row ≤ column), diagonal included
        self.upper = self.indices <= cols
        self.upper_indices = self.indices[self.upper]
        self.upper_indptr = np.searchsorted(cols[self.upper], np.arange(self.nf + 1)).astype(
            np.int64
        )
        self.diag_full = np.flatnonzero(self.indices == cols)
        self._refactor = SymmetricRefactorization()

    def _gradients(self, X: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The entries J00, J01, J10, J11 (each (m,)) of the deformation gradients of X (n, 2)."""
        x, y = X[:, 0][self.FT], X[:, 1][self.FT]  # (3, m)
        dx, dy = self.dNx, self.dNy
        return (
            x[0] * dx[0] + x[1] * dx[1] + x[2] * dx[2],
            x[0] * dy[0] + x[1] * dy[1] + x[2] * dy[2],
            y[0] * dx[0] + y[1] * dx[1] + y[2] * dx[2],
            y[0] * dy[0] + y[1] * dy[1] + y[2] * dy[2],
        )

    def jacobians(self, X: FloatArray) -> FloatArray:
        """Deformation gradients J = ∂X/∂rest, (m, 2, 2), of positions X (n, 2)."""
        J = np.zeros((self.F.shape[0], 2, 2))
        J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1] = self._gradients(X)
        return J

    def det(self, X: FloatArray) -> FloatArray:
        """det J per triangle, (m,), of positions X (n, 2): the area ratio."""
        a, b, c, d = self._gradients(X)
        return np.asarray(a * d - b * c, dtype=np.float64)

    def _strain_residual(
        self, X: FloatArray, eps_t: FloatArray
    ) -> tuple[tuple[FloatArray, FloatArray, FloatArray, FloatArray], FloatArray]:
        """J's entries (as :meth:`_gradients`) and ε'(X) − ε^t, (3, m)."""
        a, b, c, d = J = self._gradients(X)
        r = np.zeros((3, a.shape[0]))
        r[0] = 0.5 * (a * a + c * c - 1.0) - eps_t[:, 0]  # eq. (1)
        r[1] = 0.5 * (b * b + d * d - 1.0) - eps_t[:, 1]
        r[2] = a * b + c * d - eps_t[:, 2]
        return J, r

    def energy(self, X: FloatArray, eps_t: FloatArray) -> float:
        """W = ½ Σ A |ε'(X) − ε^t|² (eq. 4) of positions X (n, 2) and target strain (m, 3)."""
        _, r = self._strain_residual(X, eps_t)
        return float(0.5 * np.dot(self.area, r[0] * r[0] + r[1] * r[1] + r[2] * r[2]))

    def _strain_matrix(self, X: FloatArray, eps_t: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Strain matrix B of eq. (8), as (3 components, 6 dofs, m), and ε' − ε (3, m).

        Dof ``2 k + a`` is coordinate a of node k; B[0] = ∂N_k/∂x · J[a, 0],
        B[1] = ∂N_k/∂y · J[a, 1], B[2] = ∂N_k/∂x · J[a, 1] + ∂N_k/∂y · J[a, 0].
        """
        (a, b, c, d), r = self._strain_residual(X, eps_t)
        dx, dy = self.dNx, self.dNy  # (3, m)
        B = np.zeros((3, 3, 2, a.shape[0]))  # (component, node, xy, triangle)
        B[0, :, 0], B[0, :, 1] = dx * a, dx * c
        B[1, :, 0], B[1, :, 1] = dy * b, dy * d
        B[2, :, 0] = dx * b + dy * a
        B[2, :, 1] = dx * d + dy * c
        return B.reshape(3, 6, -1), r

    def _phi(self, B: FloatArray, r: FloatArray) -> FloatArray:
        phi_f = self.area * (B[0] * r[0] + B[1] * r[1] + B[2] * r[2])  # (6, m): eq. (9)
        return np.asarray(
            np.bincount(self.dofT.ravel(), phi_f.ravel(), minlength=2 * self.n)[self.free],
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
        data, phi = self._tangent_data(X, eps_t, extra)
        K = sp.csc_array((data, self.indices, self.indptr), shape=(self.nf, self.nf))
        return phi, K

    def tangent_upper(
        self,
        X: FloatArray,
        eps_t: FloatArray,
        extra: tuple[FloatArray, FloatArray] | None = None,
    ) -> tuple[FloatArray, sp.csc_array, sp.csc_array]:
        """:meth:`tangent`, and also K's upper triangle (diagonal included) as its own CSC array.

        The upper triangle always has the same sparsity pattern (every diagonal
        entry included), so that a factorisation's symbolic analysis can be reused.
        """
        data, phi = self._tangent_data(X, eps_t, extra)
        K = sp.csc_array((data, self.indices, self.indptr), shape=(self.nf, self.nf))
        U = sp.csc_array(
            (data[self.upper], self.upper_indices, self.upper_indptr), shape=(self.nf, self.nf)
        )
        return phi, K, U

    def factorize(self, K: sp.csc_array, U: sp.csc_array, shift: float = 0.0) -> Factorization:
        """Factorise ``K + shift · I`` from K and its upper triangle U (:meth:`tangent_upper`).

        The symbolic analysis of K's pattern is done on the first call and reused
        (:class:`conformorph.geometry.sparse_factor.SymmetricRefactorization`); the
        result is valid until the next call.
        """
        if shift != 0.0:
            K = K.copy()
            U = U.copy()
            K.data[self.diag_full] += shift
            U.data[self.upper_indptr[1:] - 1] += shift  # the diagonal ends each column
        return self._refactor.factorize(K, U)

    def _tangent_data(
        self, X: FloatArray, eps_t: FloatArray, extra: tuple[FloatArray, FloatArray] | None
    ) -> tuple[FloatArray, FloatArray]:
        """K's CSC data (in the pattern ``indices``/``indptr``) and φ."""
        B, r = self._strain_matrix(X, eps_t)
        dx, dy = self.dNx, self.dNy
        # eq. (10): Bᵀ B + Gᵀ (S' − S) G, the second term block-diagonal in xy, with
        # s_kl = ∇N_k · R ∇N_l and R = [[r0, r2], [r2, r1]]
        Kf = B[0, :, None] * B[0, None] + B[1, :, None] * B[1, None] + B[2, :, None] * B[2, None]
        s = (
            dx[:, None] * (r[0] * dx + r[2] * dy)[None]
            + dy[:, None] * (r[2] * dx + r[1] * dy)[None]
        )  # (3, 3, m)
        Kf4 = Kf.reshape(3, 2, 3, 2, -1)
        Kf4[:, 0, :, 0] += s
        Kf4[:, 1, :, 1] += s
        Kf *= self.area
        phi = self._phi(B, r)
        if extra is not None:
            Kf += extra[1].transpose(1, 2, 0)
            phi = phi + self._assemble_vector(extra[0])
        data = np.bincount(self.pos, Kf.ravel()[self.keep], minlength=self.nnz)
        return np.asarray(data, dtype=np.float64), phi

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
        its per-triangle gradient (m, 6), for ``order`` 2 its Hessian (m, 6, 6) (None below).

        ``ψ(s) = s/s0 − 1 − log(s/s0)`` below ``s0`` and 0 above: zero, with zero
        slope, while a triangle keeps at least the fraction ``s0`` of its prescribed
        area ratio ``d*``, and infinite as its area goes to 0 (inf if any is ≤ 0).
        """
        a, b, c, dd = self._gradients(X)
        d = a * dd - b * c
        if np.any(d <= 0):
            return float("inf"), None, None
        sr = d / (s0 * d_star)
        on = sr < 1.0
        wA = weight * self.area
        energy = float(np.sum(wA[on] * (sr[on] - 1.0 - np.log(sr[on]))))
        if order == 0:  # the line search's energy evaluations: nothing else is needed
            return energy, None, None
        m = d.shape[0]
        if not on.any():
            return energy, np.zeros((m, 6)), np.zeros((m, 6, 6))
        dx, dy = self.dNx, self.dNy  # (3, m)
        # ∂d/∂x_{k,a} = Σ_b cof_ab ∂N_k/∂x_b, cof = [[J11, −J10], [−J01, J00]]
        grad3 = np.zeros((3, 2, m))
        grad3[:, 0] = dd * dx - c * dy
        grad3[:, 1] = a * dy - b * dx
        grad_d = grad3.reshape(6, m)
        cc = s0 * d_star
        dpsi = np.where(on, 1.0 - 1.0 / sr, 0.0) / cc  # ψ'(s) ds/dd
        d2psi = np.where(on, 1.0 / sr**2, 0.0) / cc**2
        g = (wA * dpsi) * grad_d  # (6, m)
        if order == 1:
            return energy, g.T, None
        H = (wA * d2psi) * grad_d[:, None] * grad_d[None] + (wA * dpsi) * self._det_hessian()
        # (m, 6) and (m, 6, 6) views of the triangle-last arrays
        return energy, g.T, H.transpose(2, 0, 1)

    def _det_hessian(self) -> FloatArray:
        """∂²(det J)/∂x∂x per triangle, (6, 6, m): constant, computed once."""
        if self._hess_d is None:
            dx, dy = self.dNx, self.dNy
            # ∂²d/∂x_{k,0}∂x_{l,1} = ∂N_k/∂x ∂N_l/∂y − ∂N_k/∂y ∂N_l/∂x (and its transpose)
            cross = dx[:, None] * dy[None] - dy[:, None] * dx[None]  # (3, 3, m)
            h = np.zeros((3, 2, 3, 2, dx.shape[1]))
            h[:, 0, :, 1] = cross
            h[:, 1, :, 0] = cross.transpose(1, 0, 2)
            self._hess_d = h.reshape(6, 6, -1)
        return self._hess_d
