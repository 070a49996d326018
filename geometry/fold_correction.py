"""Reconstruction where the disk map folds: the surface's own Laplace equations, solved locally.

Algorithm 1 of the face paper solves ``Δ X = 2 H λ n`` with the disk's
Laplacian standing in for the surface's. Where the disk map folds (the ICT
faces' inner-lip fold at the mouth corners flips 18–34 triangles in every
disk map), the disk's cotangent weights have nothing to do with the
surface's, and the reconstruction's largest errors sit there
(``benchmarks/bench_reconstruct.py``: L∞ 6.2e-3 on ICT pucker against
1.9e-3–2.0e-3 on faces whose map does not fold).

There the surface ``X`` satisfies two sets of equations that involve only
the (H, λ) data, the disk and ``X`` itself, each with ``X``'s own cotangent
Laplacian ``L(X)``:

- ``L(X) X = 2 H λ A_uv`` (the data's mean-curvature vector, eq. 1 with the
  surface's operator): 3 equations a vertex;
- ``L(X) uv = 0``: the disk map is the surface's discrete harmonic map (the
  fast method's interior solves exactly that equation), 2 equations a vertex.

The first alone leaves the tangential positions free (on a flat patch any
re-meshing solves ``L(X) X = 0``: a fixed-point iteration drifts, measured
diverging after one step); the second pins them. Both hold exactly at the
true surface. :func:`fold_correction` solves them in least squares by
Levenberg–Marquardt over a few rings around the fold, everything else kept
at the linear reconstruction.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ._typing import BoolArray, FloatArray, IntArray
from .flipped_triangles import flipped_triangles
from .sparse_factor import factorize
from .tolerances import FOLD_CORRECTION_RTOL

#: Complex-step size (Squire and Trapp 1998): derivatives exact to rounding for
#: any step this small, since no difference of nearby values is taken.
_COMPLEX_STEP = 1e-30


@dataclass(frozen=True)
class FoldCorrectionInfo:
    """Diagnostics of :func:`fold_correction`.

    Attributes
    ----------
    vertices : int
        Vertices moved (the fold's vertices and ``rings`` rings around them,
        boundary excluded).
    iterations : int
        Accepted Levenberg–Marquardt steps.
    residual_history : list of float
        Norm of the stacked residual (see :func:`fold_residual`) before the
        first and after each accepted step.
    stop_reason : str
        ``"no_fold"`` (nothing to correct), ``"converged"`` (a step lowered the
        residual by less than ``tol`` of it), ``"max_iterations"`` or
        ``"no_descent"`` (no damping gave a lower residual).
    """

    vertices: int
    iterations: int
    residual_history: list[float]
    stop_reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


def _triangle_terms(P: Any, Q: FloatArray) -> Any:
    """Per-triangle contributions to ``L(X) X`` and ``L(X) uv`` at its corners.

    Parameters
    ----------
    P : (t, 3, 3) float64 or complex128
        Corner positions in 3D.
    Q : (t, 3, 2) float64
        Corner positions on the disk.

    Returns
    -------
    (t, 3, 5) same dtype as P
        ``[..., :3]``: the triangle's part of ``(L(X) X)_i`` at each corner i;
        ``[..., 3:]``: of ``(L(X) uv)_i``. With ``w = cot(θ_k)/2`` for the
        angle at corner k, edge (i, j) opposite it adds ``w (x_i − x_j)`` at i
        and ``w (x_j − x_i)`` at j (the PSD convention of
        :func:`conformorph.geometry.cotangent_laplacian`).
    """
    out = np.zeros(P.shape[:2] + (5,), dtype=P.dtype)
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        a = P[:, i] - P[:, k]
        b = P[:, j] - P[:, k]
        c = np.cross(a, b)
        # sqrt(c·c), not |c|: analytic, so the complex step differentiates it
        w = 0.5 * (a * b).sum(axis=1) / np.sqrt((c * c).sum(axis=1))
        d = np.concatenate([P[:, i] - P[:, j], Q[:, i] - Q[:, j]], axis=1)
        out[:, i] += w[:, None] * d
        out[:, j] -= w[:, None] * d
    return out


def fold_residual(
    X: FloatArray, F: IntArray, uv: FloatArray, rhs: FloatArray, scale: float
) -> FloatArray:
    """Residual of the surface's Laplace equations at every vertex.

    Parameters
    ----------
    X : (n, 3) float64
        Surface.
    F : (m, 3) int64
    uv : (n, 2) float64
        Its disk map.
    rhs : (n, 3) float64
        ``2 H λ A_uv``, the integrated mean-curvature vector.
    scale : float
        Length that makes the disk's equations commensurate with the
        surface's (the boundary's bounding-box diagonal).

    Returns
    -------
    R : (n, 5) float64
        ``[L(X) X − rhs, scale · L(X) uv]``; zero at interior vertices when
        ``X`` is the surface that ``rhs`` was measured on and ``uv`` its
        discrete harmonic map.
    """
    terms = _triangle_terms(X[F], uv[F])
    R = np.zeros((X.shape[0], 5))
    np.add.at(R, F.ravel(), terms.reshape(-1, 5))
    R[:, :3] -= rhs
    R[:, 3:] *= scale
    return R


def fold_region(F: IntArray, uv: FloatArray, b: IntArray, rings: int) -> BoolArray:
    """Interior vertices of the triangles flipped in ``uv``, grown by ``rings`` rings.

    Parameters
    ----------
    F : (m, 3) int64
    uv : (n, 2) float64
    b : (k,) int64
        Boundary vertices (never in the region).
    rings : int
        Rings of neighbours added.

    Returns
    -------
    (n,) bool
    """
    region = np.zeros(uv.shape[0], dtype=bool)
    region[F[flipped_triangles(uv, F)].ravel()] = True
    for _ in range(rings):
        region[F[region[F].any(axis=1)].ravel()] = True
    region[b] = False
    return region


def fold_correction(
    X: FloatArray,
    F: IntArray,
    uv: FloatArray,
    rhs: FloatArray,
    b: IntArray,
    *,
    rings: int = 4,
    max_iterations: int = 30,
    tol: float = FOLD_CORRECTION_RTOL,
) -> tuple[FloatArray, FoldCorrectionInfo]:
    """Correct a reconstruction near the disk map's folds by the surface's own Laplace equations.

    Moves the vertices of :func:`fold_region` to minimise ``|R|²`` of
    :func:`fold_residual` (rows of those vertices), everything else fixed:
    Levenberg–Marquardt with the Jacobian of every triangle's terms by the
    complex step, damping ``μ diag(JᵀJ)`` (Marquardt's scaling), a step kept
    only when it lowers the residual.

    Parameters
    ----------
    X : (n, 3) float64
        The linear reconstruction (:func:`conformorph.geometry.reconstruct_surface`).
    F : (m, 3) int64
    uv : (n, 2) float64
        The disk map: the surface's discrete harmonic map (the fast method's
        map before angle refinement, which is what reconstruction uses).
    rhs : (n, 3) float64
        ``2 H λ A_uv``.
    b : (k,) int64
        Boundary vertices.
    rings : int
        Rings around the flipped triangles' vertices that move too. Measured
        on ICT pucker and sad: 2 rings leave L∞ at 5.3e-3, 4 and 6 rings both
        reach 2.0e-3, the level of faces whose map does not fold.
    max_iterations : int
        Cap on accepted steps.
    tol : float
        Stop when a step lowers the residual by less than this fraction.

    Returns
    -------
    X : (n, 3) float64
        A new array; ``X`` itself is not modified.
    info : FoldCorrectionInfo

    Notes
    -----
    The equations hold exactly at the true surface, so where the linear
    reconstruction is already right nothing moves; the method needs the
    disk to be the harmonic map (a Möbius-normalised or angle-refined disk
    does not satisfy ``L(X) uv = 0``, and the correction would then trade
    one error for another).
    """
    X = np.array(X, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    uv = np.asarray(uv, dtype=np.float64)
    rhs = np.asarray(rhs, dtype=np.float64)
    b = np.asarray(b, dtype=np.int64)
    n = X.shape[0]
    if X.shape != (n, 3) or uv.shape != (n, 2) or rhs.shape != (n, 3):
        raise ValueError(
            f"X, uv and rhs must have shapes (n, 3), (n, 2), (n, 3); got {X.shape}, "
            f"{uv.shape}, {rhs.shape}"
        )
    if rings < 0 or max_iterations < 0:
        raise ValueError(f"rings and max_iterations must be >= 0, got {rings}, {max_iterations}")
    region = fold_region(F, uv, b, rings)
    if not region.any():
        return X, FoldCorrectionInfo(0, 0, [], "no_fold")
    T = F[region[F].any(axis=1)]  # the triangles whose terms the region's rows or positions touch
    rows = np.flatnonzero(region)
    local = np.full(n, -1, dtype=np.int64)
    local[rows] = np.arange(rows.size)
    scale = float(np.linalg.norm(np.ptp(X[b], axis=0))) or 1.0

    def residual(Y: FloatArray) -> FloatArray:
        return fold_residual(Y, T, uv, rhs, scale)[rows].ravel()

    R = residual(X)
    history = [float(np.linalg.norm(R))]
    mu = 1e-3
    stop = "max_iterations"
    it = 0
    while it < max_iterations:
        J = _jacobian(X, T, uv, scale, local, rows.size)
        JT = J.T.tocsr()
        A = (JT @ J).tocsc()
        D = sp.diags_array(A.diagonal())
        g = -(JT @ R)
        accepted = False
        while mu < 1e12:
            step = factorize((A + mu * D).tocsc(), symmetric=True).solve(g)
            trial = X.copy()
            trial[rows] += step.reshape(-1, 3)
            R_trial = residual(trial)
            if np.linalg.norm(R_trial) < history[-1]:
                accepted = True
                break
            mu *= 4.0
        if not accepted:
            stop = "no_descent"
            break
        X, R = trial, R_trial
        mu = max(mu / 3.0, 1e-12)
        it += 1
        history.append(float(np.linalg.norm(R)))
        if history[-2] - history[-1] < tol * history[-2]:
            stop = "converged"
            break
    return X, FoldCorrectionInfo(int(rows.size), it, history, stop)


def _jacobian(
    X: FloatArray, T: IntArray, uv: FloatArray, scale: float, local: IntArray, k: int
) -> sp.csr_array:
    """Jacobian (5k, 3k) of the region's residual rows by the region's positions."""
    P = X[T].astype(np.complex128)
    Q = uv[T]
    blocks = np.zeros((T.shape[0], 3, 5, 3, 3))  # triangle, corner row, equation, corner col, xyz
    for a in range(3):
        for d in range(3):
            Pp = P.copy()
            Pp[:, a, d] += 1j * _COMPLEX_STEP
            blocks[:, :, :, a, d] = _triangle_terms(Pp, Q).imag / _COMPLEX_STEP
    blocks[:, :, 3:] *= scale
    lr = local[T]
    row = lr[:, :, None, None, None] * 5 + np.arange(5)[None, None, :, None, None]
    col = lr[:, None, None, :, None] * 3 + np.arange(3)[None, None, None, None, :]
    row, col = np.broadcast_arrays(row, col, blocks)[:2]
    keep = (row >= 0) & (col >= 0)
    return sp.csr_array(
        (blocks[keep], (row[keep], col[keep])), shape=(5 * k, 3 * k), dtype=np.float64
    )
