"""The project's one sparse-solver policy: factorise once, solve many, never ignore a singular solve.

Measured on this project's machine (2 vCPU, see ``benchmarks/bench_solvers.py``)
on the interior cotangent Laplacian of ``choi_human_face`` (17k vertices) and
of its once-subdivided version (68k):

=================  ===========  ===========  =============
solver             factor 17k   factor 68k   2 solves 68k
=================  ===========  ===========  =============
qdldl (AMD + LDL)  0.075 s      0.63 s       0.040 s
SuperLU (COLAMD)   0.128 s      1.05 s       0.052 s
cholespy           0.191 s      0.98 s       0.014 s
=================  ===========  ===========  =============

so symmetric matrices are factorised with QDLDL (an LDLᵀ factorisation with
AMD ordering, shipped as a wheel) and unsymmetric ones, symmetric ones that
QDLDL rejects as not quasi-definite, or any matrix when QDLDL is not
installed, with SuperLU (COLAMD ordering, partial pivoting). Both paths check that
every solution is finite and has a small residual, and raise
:class:`~conformorph.geometry.mesh_errors.SingularSystemError` otherwise: scipy's
``spsolve`` only *warns* on a singular matrix and returns NaN.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ._typing import FloatArray
from .mesh_errors import SingularSystemError
from .tolerances import SOLVE_RESIDUAL_RTOL

try:  # optional: faster symmetric factorisation
    import qdldl as _qdldl
except ImportError:  # pragma: no cover - exercised only where qdldl is absent
    _qdldl = None


@dataclass
class Factorization:
    """A factorised square sparse matrix; call :meth:`solve` for any right-hand side.

    Attributes
    ----------
    A : (n, n) csc_array
        The matrix that was factorised (kept for residual checks).
    backend : str
        ``"qdldl"`` or ``"superlu"``.
    """

    A: sp.csc_array
    backend: str
    _solver: Any

    def solve(self, b: FloatArray) -> FloatArray:
        """Solve ``A x = b``.

        Parameters
        ----------
        b : (n,) or (n, k) float64
            Right-hand side(s).

        Returns
        -------
        x : same shape as b, float64

        Raises
        ------
        SingularSystemError
            If the solution is not finite or its relative residual
            ``max|A x - b| / max|b|`` exceeds
            :data:`~conformorph.geometry.tolerances.SOLVE_RESIDUAL_RTOL`.
        """
        b = np.asarray(b, dtype=np.float64)
        cols = b.reshape(b.shape[0], -1)
        x = self.precondition(cols)
        # relative to b, not to |A||x|: a (near-)singular factor returns a huge
        # x whose residual is small relative to |A||x| but not to |b|
        r = np.abs(self.A @ x - cols).max(initial=0.0)
        scale = np.abs(cols).max(initial=0.0)
        if r > SOLVE_RESIDUAL_RTOL * scale:
            raise SingularSystemError(
                f"{self.backend}: residual {r:.2e} exceeds {SOLVE_RESIDUAL_RTOL:.0e} × |b| "
                f"= {SOLVE_RESIDUAL_RTOL * scale:.2e}; the matrix is numerically singular"
            )
        return x.reshape(b.shape)

    def precondition(self, b: FloatArray) -> FloatArray:
        """Apply the factorisation's inverse to ``b`` without the residual check.

        For a preconditioner (:func:`preconditioned_cg`), whose accuracy the
        iteration's own residual test decides: on an ill-conditioned matrix
        (the non-rigid ICP's bi-Laplacian on 68k nodes) a solve with a tiny
        right-hand side can miss :meth:`solve`'s relative residual test by
        rounding alone, which is no reason to stop CG.

        Parameters
        ----------
        b : (n,) or (n, k) float64

        Returns
        -------
        x : same shape as b, float64

        Raises
        ------
        SingularSystemError
            If the result is not finite.
        """
        b = np.asarray(b, dtype=np.float64)
        if b.shape[0] != self.A.shape[0]:
            raise ValueError(f"right-hand side has {b.shape[0]} rows, matrix has {self.A.shape[0]}")
        cols = b.reshape(b.shape[0], -1)
        x = np.zeros_like(cols)
        for k in range(cols.shape[1]):
            x[:, k] = self._solver.solve(np.ascontiguousarray(cols[:, k]))
        if not np.all(np.isfinite(x)):
            raise SingularSystemError(f"{self.backend}: solve produced non-finite values")
        return x.reshape(b.shape)


def _norm1(A: sp.csc_array) -> float:
    return float(np.abs(A).sum(axis=0).max())


def factorize(A: sp.sparray | sp.spmatrix, *, symmetric: bool | None = None) -> Factorization:
    """Factorise a square sparse matrix once, for reuse with many right-hand sides.

    Parameters
    ----------
    A : (n, n) sparse array
        The matrix. Not modified.
    symmetric : bool, optional
        Whether ``A`` is symmetric; detected when not given.

    Returns
    -------
    Factorization

    Raises
    ------
    SingularSystemError
        If the factorisation fails (structurally or numerically singular).
    ValueError
        If ``A`` is not square or has non-finite entries.
    """
    A = sp.csc_array(A, dtype=np.float64)
    if A.shape[0] != A.shape[1]:
        raise ValueError(f"matrix must be square, got shape {A.shape}")
    if not np.all(np.isfinite(A.data)):
        raise ValueError("matrix has non-finite entries")
    if symmetric is None:
        d = A - A.T
        symmetric = d.nnz == 0 or float(np.abs(d).max()) <= 1e-12 * max(_norm1(A), 1e-300)
    if symmetric and _qdldl is not None:
        try:
            return Factorization(A, "qdldl", _qdldl.Solver(A))
        except (RuntimeError, ValueError):
            # QDLDL needs a quasi-definite matrix; an indefinite but regular one
            # (e.g. a cotangent Laplacian with many negative weights) goes to
            # SuperLU below, which pivots, and only fails if truly singular
            pass
    with warnings.catch_warnings():
        warnings.simplefilter("error", sla.MatrixRankWarning)
        try:
            solver = sla.splu(A, permc_spec="COLAMD")
        except (RuntimeError, sla.MatrixRankWarning) as exc:
            raise SingularSystemError(f"superlu: factorisation failed: {exc}") from exc
    return Factorization(A, "superlu", solver)


class SymmetricRefactorization:
    """Factorise a sequence of symmetric matrices of one sparsity pattern, reusing the analysis.

    Newton's method factorises a tangent matrix of a fixed pattern at every
    step; :func:`factorize` redoes QDLDL's ordering (AMD) and elimination tree
    each time. Here the first call analyses the pattern and every later call
    only refactorises numerically (``qdldl.Solver.update``): on the strain
    morph's tangent (1243 unknowns, 9086 upper-triangle entries) 0.33 ms
    instead of 1.2 ms. Where QDLDL is absent or fails on a matrix (a zero pivot
    of an indefinite one), that call goes through :func:`factorize` (SuperLU)
    and the next call analyses again.

    Every matrix passed must have the same upper-triangle pattern (row ≤ column,
    every diagonal entry present, rows sorted within each column). A
    :class:`Factorization` returned is valid until the next call of
    :meth:`factorize`, which overwrites its factors.
    """

    def __init__(self) -> None:
        self._solver: Any = None
        self._nnz = -1

    def factorize(self, A: sp.csc_array, upper: sp.csc_array) -> Factorization:
        """Factorise ``A`` given also as its upper triangle ``upper``.

        Parameters
        ----------
        A : (n, n) csc_array
            The symmetric matrix (kept by the result for its residual check).
        upper : (n, n) csc_array
            Its upper triangle, diagonal included, in the fixed pattern.

        Returns
        -------
        Factorization

        Raises
        ------
        SingularSystemError
            If no backend factorises ``A``.
        ValueError
            If ``upper`` changed its number of entries, or a matrix has non-finite entries.
        """
        if not (np.all(np.isfinite(upper.data)) and np.all(np.isfinite(A.data))):
            raise ValueError("matrix has non-finite entries")
        if _qdldl is None:  # pragma: no cover - exercised only where qdldl is absent
            return factorize(A, symmetric=True)
        if self._solver is not None and upper.nnz != self._nnz:
            raise ValueError(
                f"upper triangle has {upper.nnz} entries, the analysed pattern {self._nnz}"
            )
        try:
            if self._solver is None:
                self._solver = _qdldl.Solver(upper, upper=True)
                self._nnz = upper.nnz
            else:
                self._solver.update(upper, upper=True)
        except (RuntimeError, ValueError):
            self._solver = None
            return factorize(A, symmetric=True)
        return Factorization(A, "qdldl", self._solver)


def preconditioned_cg(
    A: object,
    b: FloatArray,
    fac: Factorization,
    x0: FloatArray,
    *,
    rtol: float,
    max_iterations: int,
) -> tuple[FloatArray | None, int]:
    """Preconditioned CG on every column of ``b`` in lock step; None when it does not converge fast.

    The sparse policy's way to solve with a matrix close to one already
    factorised (consecutive morph frames, ICP iterations at one stiffness):
    the old factorisation preconditions CG, and a solve that does not converge
    within ``max_iterations`` is reported (None), never returned, so that the
    caller factorises the new matrix instead. The columns (e.g. x, y, z) run
    independent CG recurrences (their own step lengths), but share every
    preconditioner application: one call of ``fac.precondition`` on the (p, c) block
    per iteration instead of one per column per iteration, and no Python loop
    over columns.

    Parameters
    ----------
    A : (p, p) sparse, symmetric positive definite
        The matrix to solve with.
    b : (p, c) float64
        Right-hand sides.
    fac : Factorization
        A factorisation of a nearby matrix (the preconditioner).
    x0 : (p, c) float64
        Starting guess.
    rtol : float
        Relative residual to reach, per column.

    Returns
    -------
    x : (p, c) float64 or None
        None when some column has not reached the relative residual
        ``rtol`` after ``max_iterations`` iterations, or when ``A`` is not
        positive definite along a search direction, or x is not finite.
    iterations : int
    """
    bn = np.linalg.norm(b, axis=0)
    goal = rtol * np.where(bn > 0, bn, 1.0)
    x = np.array(x0, dtype=np.float64, copy=True)
    r = b - A @ x  # type: ignore[operator]
    active = np.linalg.norm(r, axis=0) > goal  # columns still iterating
    if not active.any():
        return x, 0
    z = fac.precondition(r)
    d = z.copy()
    rz = np.einsum("ij,ij->j", r, z)
    for it in range(1, max_iterations + 1):
        Ad = A @ d  # type: ignore[operator]
        dAd = np.einsum("ij,ij->j", d, Ad)
        if np.any(dAd[active] <= 0) or not np.all(np.isfinite(dAd[active])):
            return None, it  # not positive definite along d: let the caller factorise
        # converged columns stay put (their residual may be exactly 0: no 0/0)
        alpha = np.where(active, rz / np.where(active, dAd, 1.0), 0.0)
        x += alpha * d
        r -= alpha * Ad
        active &= np.linalg.norm(r, axis=0) > goal
        if not active.any():
            return (x, it) if np.all(np.isfinite(x)) else (None, it)
        z = fac.precondition(r)
        rz_new = np.einsum("ij,ij->j", r, z)
        beta = np.where(active, rz_new / np.where(active, rz, 1.0), 0.0)
        d = z + beta * d
        rz = rz_new
    return None, max_iterations
