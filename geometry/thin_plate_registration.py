"""The elastic part of DMT: a modified thin-plate spline deformation of the unit disk.

Section 3 of the face morphing paper: after the optimal Möbius transformation
(MT), the remaining landmark mismatch is removed by a deformation built from
the biharmonic kernel :math:`\\psi_j(x) = r_j^2 \\log r_j`, :math:`r_j = |x - c_j|`,
scaled at every centre by the ratio of conformal factors,
:math:`\\tilde\\psi_j = \\lambda_1^2(c_j) \\lambda_0^{-2}(c_j) \\psi_j`; the
coefficients solve a least-squares problem by QR when n ≤ m and by Tikhonov
regularisation :math:`(\\varepsilon I + S^\\top S)\\alpha = S^\\top q` when n > m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray
from .landmark_pairs import landmark_rms, validate_landmark_pairs
from .threads import map_in_threads, row_blocks

#: Tikhonov parameter of the paper (section 3, "ε = 5 × 10⁻³") used when there
#: are more centres than landmarks.
TPS_TIKHONOV_EPS = 5e-3


def _kernel(r: FloatArray) -> FloatArray:
    """ψ(r) = r² log r, continuously extended by ψ(0) = 0."""
    out = np.zeros_like(r)
    nz = r > 0
    out[nz] = r[nz] ** 2 * np.log(r[nz])
    return out


def _kernel_derivative_over_r(r: FloatArray) -> FloatArray:
    """ψ'(r)/r = 2 log r + 1 (→ −∞ at 0, but multiplied by x − c which → 0)."""
    out = np.zeros_like(r)
    nz = r > 0
    out[nz] = 2.0 * np.log(r[nz]) + 1.0
    return out


@dataclass(frozen=True)
class ThinPlateDeformation:
    """The deformation :math:`x \\mapsto x + w(x)\\,g(x)` of the unit disk.

    :math:`g(x) = \\sum_j \\alpha_j s_j \\psi(|x - c_j|) + \\beta^\\top (1, x_1, x_2)`
    and :math:`w(x) = 1 - |x|^2` when ``boundary_taper`` (else ``w = 1``).

    Attributes
    ----------
    centers : (n, 2) float64
        Kernel centres :math:`c_j`.
    kernel_scale : (n,) float64
        :math:`s_j = \\lambda_1^2(c_j) / \\lambda_0^2(c_j)`.
    alpha : (n, 2) float64
        Kernel coefficients, one column per coordinate.
    beta : (3, 2) float64
        Affine coefficients (zero when the affine part is off).
    boundary_taper : bool
        Whether the displacement is multiplied by ``1 - |x|²``.
    """

    centers: FloatArray
    kernel_scale: FloatArray
    alpha: FloatArray
    beta: FloatArray
    boundary_taper: bool

    def kernel_matrix(self, uv: FloatArray) -> FloatArray:
        """Matrix :math:`[s_j \\psi(|x_i - c_j|)]`, shape (p, n)."""
        # ψ(r) = r² log r = ½ r² log r², without the square root; in place, since this
        # (p, n) evaluation is the cost of every apply. r² is floored at the smallest
        # normal double, where ½ r² log r² is below 1e-305: ψ(0) = 0 to double precision.
        K = uv @ (-2.0 * self.centers.T)
        K += np.sum(uv**2, axis=1)[:, None]
        K += np.sum(self.centers**2, axis=1)[None, :]
        np.maximum(K, np.finfo(np.float64).tiny, out=K)
        logK = np.log(K)
        K *= logK
        K *= 0.5 * self.kernel_scale[None, :]
        return K

    def displacement_basis(self, uv: FloatArray) -> FloatArray:
        """Matrix :math:`[s_j \\psi(|x_i - c_j|) \\;|\\; 1, x_1, x_2]`, shape (p, n + 3)."""
        return np.hstack([self.kernel_matrix(uv), np.ones((uv.shape[0], 1)), uv])

    def apply(self, uv: FloatArray) -> FloatArray:
        """Apply the deformation.

        Parameters
        ----------
        uv : (p, 2) float64

        Returns
        -------
        (p, 2) float64
        """
        uv = np.asarray(uv, dtype=np.float64)

        def chunk(x: FloatArray) -> FloatArray:
            g = self.kernel_matrix(x) @ self.alpha + self.beta[0] + x @ self.beta[1:]
            w = 1.0 - np.sum(x**2, axis=1) if self.boundary_taper else np.ones(x.shape[0])
            return np.asarray(x + w[:, None] * g)

        if uv.shape[0] == 0:
            return np.zeros_like(uv)
        # chunks of ≤ 4096 points bound the (p, n) kernel matrix; threads share them
        return np.concatenate(map_in_threads(chunk, row_blocks(uv, 4096, 1024)))

    def jacobian(self, uv: FloatArray) -> FloatArray:
        """Jacobian matrices of the deformation at points.

        Parameters
        ----------
        uv : (p, 2) float64

        Returns
        -------
        J : (p, 2, 2) float64
            ``J[i, k, l] = ∂f_k/∂x_l`` at point i.
        """
        uv = np.asarray(uv, dtype=np.float64)
        J = np.zeros((uv.shape[0], 2, 2))
        for s in range(0, uv.shape[0], 4096):
            x = uv[s : s + 4096]
            diff = x[:, None, :] - self.centers[None, :, :]  # (p, n, 2)
            r = np.linalg.norm(diff, axis=2)
            dK = (_kernel_derivative_over_r(r) * self.kernel_scale)[:, :, None] * diff
            # ∂g_k/∂x_l = Σ_j α_jk dK_jl + β_{1+l, k}
            dg = np.einsum("pjl,jk->pkl", dK, self.alpha) + self.beta[1:].T[None, :, :]
            g = self.kernel_matrix(x) @ self.alpha + self.beta[0] + x @ self.beta[1:]
            if self.boundary_taper:
                w = 1.0 - np.sum(x**2, axis=1)
                dw = -2.0 * x
            else:
                w = np.ones(x.shape[0])
                dw = np.zeros_like(x)
            Js = np.eye(2)[None] + w[:, None, None] * dg + g[:, :, None] * dw[:, None, :]
            J[s : s + 4096] = Js
        return J


def _condition(M: FloatArray) -> float:
    """2-norm condition number for small systems; NaN above 200 unknowns (an SVD would dominate)."""
    if max(M.shape) > 200:
        return float("nan")
    return float(np.linalg.cond(M))


@dataclass(frozen=True)
class ThinPlateFitInfo:
    """Diagnostics of :func:`thin_plate_registration`.

    Attributes
    ----------
    solver : str
        ``"qr"`` (n ≤ m, least squares by QR), ``"tps_interpolation"`` (n = m
        with the affine part: the classical thin-plate interpolation system),
        or ``"tikhonov"``.
    regularization : float
        ε used (0 for the QR and interpolation solvers).
    rms_before, rms_after : float
        Root-mean-square landmark distance before and after the deformation.
    condition_number : float
        2-norm condition number of the solved matrix (NaN for more than 200
        unknowns, where computing it would cost more than the fit).
    """

    solver: str
    regularization: float
    rms_before: float
    rms_after: float
    condition_number: float


def _fit_coefficients(
    S: FloatArray,
    A: FloatArray,
    G: FloatArray,
    eps: float,
    *,
    affine: bool,
    interpolate: bool,
    smoothing: FloatArray | None = None,
) -> tuple[FloatArray, str, float]:
    """Kernel and affine coefficients (n + 3, 2) of the displacement fit S α + A β ≈ G.

    Parameters
    ----------
    S : (m, n) float64
        Kernel basis at the landmarks.
    A : (m, 3) float64
        Affine basis there.
    G : (m, 2) float64
        The displacement to reach.
    eps : float
        Tikhonov ε (> 0: the smoothing solve, ε on the kernel block only).
    affine : bool
        Fit the affine part (else β = 0).
    interpolate : bool
        The centres are the landmarks: with ε = 0 and ``affine``, the classical
        thin-plate interpolation system [S A; Aᵀ 0].
    smoothing : (n,) float64, optional
        Per-landmark smoothing Λ (centres at the landmarks only): the smoothing
        thin-plate system [S + Λ, A; Aᵀ 0] (ε = 0), or the Tikhonov fit with the
        rows weighted ε / (ε + Λ_i).

    Returns
    -------
    coef : (n + 3, 2) float64
    solver : {"tikhonov", "tps_interpolation", "tps_smoothing", "qr"}
    condition : float
    """
    n = S.shape[1]
    lam = np.zeros(n) if smoothing is None else smoothing
    if eps > 0:
        solver = "tikhonov"
        # rows weighted ε / (ε + Λ_i): a landmark of larger smoothing counts less
        rw = np.ones((S.shape[0], 1)) if smoothing is None else (eps / (eps + lam))[:, None]
        if affine:
            # min |S α + A β − G|²_W + ε |α|²  (normal equations, ε on the kernel block only)
            M = np.hstack([S, A])
            N: FloatArray = M.T @ (rw * M)
            N[np.arange(n), np.arange(n)] += eps  # no dense (n + 3)² diagonal matrix
            coef = np.linalg.solve(N, M.T @ (rw * G))
        else:
            N = np.asarray(S.T @ (rw * S), dtype=np.float64)
            N[np.arange(n), np.arange(n)] += eps
            coef = np.vstack([np.linalg.solve(N, S.T @ (rw * G)), np.zeros((3, 2))])
        cond = _condition(N)
    elif affine and interpolate:
        solver = "tps_interpolation" if smoothing is None else "tps_smoothing"
        K = np.block([[S + np.diag(lam), A], [A.T, np.zeros((3, 3))]])
        rhs = np.vstack([G, np.zeros((3, 2))])
        try:  # square and (for distinct, non-collinear landmarks) non-singular
            coef = np.linalg.solve(K, rhs)
        except np.linalg.LinAlgError:
            coef = np.linalg.lstsq(K, rhs, rcond=None)[0]
        cond = _condition(K)
    else:
        solver = "qr"
        M = np.hstack([S, A]) if affine else S
        coef = np.linalg.lstsq(M, G, rcond=None)[0]
        if not affine:
            coef = np.vstack([coef, np.zeros((3, 2))])
        cond = _condition(M)
    return np.asarray(coef, dtype=np.float64), solver, cond


def _checked_smoothing(
    smoothing: FloatArray | None, P: FloatArray, centers: FloatArray | None
) -> FloatArray | None:
    """``smoothing`` as an (m,) array ≥ 0, refused unless the centres are the landmarks."""
    if smoothing is None:
        return None
    m = P.shape[0]
    lam = np.asarray(smoothing, dtype=np.float64)
    if lam.shape != (m,) or not np.all(np.isfinite(lam)) or np.any(lam < 0):
        raise ValueError(f"smoothing must be ({m},) non-negative and finite, got {lam.shape}")
    if centers is not None and not (centers.shape == P.shape and np.array_equal(centers, P)):
        raise ValueError("smoothing needs the kernel centres at the landmarks")
    return lam


def thin_plate_registration(
    source_uv: FloatArray,
    target_uv: FloatArray,
    *,
    centers: FloatArray | None = None,
    kernel_scale: FloatArray | None = None,
    regularization: float | None = None,
    affine: bool = True,
    boundary_taper: bool = True,
    smoothing: FloatArray | None = None,
) -> tuple[ThinPlateDeformation, ThinPlateFitInfo]:
    """Fit the modified thin-plate deformation taking landmarks P to Q on the disk.

    Parameters
    ----------
    source_uv : (m, 2) float64
        Landmarks P (already moved by the MT) inside the unit disk.
    target_uv : (m, 2) float64
        Landmarks Q on the target disk.
    centers : (n, 2) float64, optional
        Kernel centres; default the source landmarks (n = m).
    kernel_scale : (n,) float64, optional
        :math:`\\lambda_1^2(c_j) / \\lambda_0^2(c_j)`, positive; default 1.
    regularization : float, optional
        Tikhonov ε. Default (None) follows the paper: 0 (exact least squares by
        QR) when n ≤ m, :data:`TPS_TIKHONOV_EPS` when n > m. A positive value
        always gives the Tikhonov (smoothing) solve.
    affine : bool, default True
        Add an affine part to the displacement (see Notes).
    boundary_taper : bool, default True
        Multiply the displacement by :math:`1 - |x|^2` (see Notes).
    smoothing : (m,) float64, optional
        Per-landmark Λ_i ≥ 0 (centres at the landmarks): the smoothing spline (S + Λ)α + Aβ
        = G, Aᵀα = 0, residual Λ_i α_i; with ε > 0, rows weighted ε / (ε + Λ_i) instead.
    Returns
    -------
    deformation : ThinPlateDeformation
    info : ThinPlateFitInfo

    Raises
    ------
    ValueError
        On bad shapes, non-finite values, fewer than 3 landmarks, non-positive
        ``kernel_scale`` or landmarks on or outside the unit circle when
        ``boundary_taper`` is on.

    Notes
    -----
    Departures from the paper, both deliberate and switchable:

    * The paper writes the map itself as :math:`\\bar f_k = \\sum_j \\alpha_j^{(k)}
      \\tilde\\psi_j`, with no affine part. The kernel's span contains
      neither constants nor the identity, so that map cannot even reproduce the
      identity when P = Q. We therefore fit the *displacement* :math:`\\bar f(x) - x`,
      which is zero when the landmarks already agree, and (``affine=True``) add
      the affine part :math:`\\beta^\\top(1, x_1, x_2)` of the classical thin-plate
      spline, so that a global shift/shear left over by the MT is not paid for by
      the kernels. With n = m centres at the landmarks and ε = 0 this is the
      classical thin-plate interpolation system
      :math:`[S\\; P;\\; P^\\top\\; 0]`, solved by QR (least squares).
    * The r² log r kernel grows without bound, so the deformation would move the
      unit circle. With ``boundary_taper`` the displacement is multiplied by
      :math:`w(x) = 1 - |x|^2` (the landmark targets are divided by
      :math:`w(p_i)` before the fit), so the circle is fixed pointwise and the
      composed map MT followed by this deformation keeps the MT's boundary
      correspondence, as the paper assumes ("the correspondence of the boundary
      points ... are known").
    * Scaling a kernel by a constant :math:`s_j` does not change the paper's
      exact least-squares fit (no affine part, QR, ε = 0): the scaled columns
      span the same space. It matters for the Tikhonov solve, where it
      reweights the penalty per centre, and for the interpolation system with
      the affine part, whose side conditions act on the coefficients.

    Whether the result is a bijection is checked by the caller
    (:mod:`conformorph.geometry.map_jacobian`): this function only fits.

    Examples
    --------
    >>> import numpy as np
    >>> P = np.array([[0.0, 0.0], [0.3, 0.1], [-0.2, 0.3], [0.1, -0.4]])
    >>> Q = P + np.array([[0.02, 0.0], [0.0, 0.01], [-0.01, 0.0], [0.0, 0.0]])
    >>> d, info = thin_plate_registration(P, Q)
    >>> bool(np.abs(d.apply(P) - Q).max() < 1e-10)
    True
    """
    P, Q = validate_landmark_pairs(source_uv, target_uv, min_count=3, fit="the thin-plate spline")
    m = P.shape[0]
    C = P.copy() if centers is None else np.asarray(centers, dtype=np.float64)
    if C.ndim != 2 or C.shape[1] != 2 or C.shape[0] < 1 or not np.all(np.isfinite(C)):
        raise ValueError(f"centers must be a finite (n, 2) array, got shape {C.shape}")
    n = C.shape[0]
    s = np.ones(n) if kernel_scale is None else np.asarray(kernel_scale, dtype=np.float64)
    if s.shape != (n,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise ValueError(f"kernel_scale must be ({n},) positive and finite, got {s.shape}")
    if regularization is not None and (not np.isfinite(regularization) or regularization < 0):
        raise ValueError(f"regularization must be ≥ 0, got {regularization}")
    lam = _checked_smoothing(smoothing, P, None if centers is None else C)
    w = np.ones(m)
    if boundary_taper:
        w = 1.0 - np.sum(P**2, axis=1)
        if np.any(w <= 1e-12):
            raise ValueError(
                "with boundary_taper, landmarks must lie strictly inside the unit disk"
            )
    G = (Q - P) / w[:, None]  # the displacement g must take at the landmarks
    eps = (TPS_TIKHONOV_EPS if n > m else 0.0) if regularization is None else regularization

    proto = ThinPlateDeformation(C, s, np.zeros((n, 2)), np.zeros((3, 2)), boundary_taper)
    B = proto.displacement_basis(P)  # (m, n + 3)
    S, A = B[:, :n], B[:, n:]
    same_centres = n == m and np.allclose(C, P, atol=0.0, rtol=0.0)
    coef, solver, cond = _fit_coefficients(
        S, A, G, eps, affine=affine, interpolate=same_centres, smoothing=lam
    )
    if not np.all(np.isfinite(coef)):
        raise ArithmeticError("thin-plate fit produced non-finite coefficients")
    d = ThinPlateDeformation(C, s, coef[:n].copy(), coef[n:].copy(), boundary_taper)
    rms_before = landmark_rms(P, Q)
    rms_after = landmark_rms(d.apply(P), Q)
    return d, ThinPlateFitInfo(solver, float(eps), rms_before, rms_after, cond)


@dataclass(frozen=True)
class ComposedDeformation:
    """A composition of thin-plate deformations, applied first to last.

    Attributes
    ----------
    steps : tuple of ThinPlateDeformation
    """

    steps: tuple[ThinPlateDeformation, ...]

    def apply(self, uv: FloatArray) -> FloatArray:
        """Apply every step in order, (p, 2) → (p, 2)."""
        z = np.asarray(uv, dtype=np.float64)
        for d in self.steps:
            z = d.apply(z)
        return z


def stepwise_thin_plate_registration(
    source_uv: FloatArray,
    target_uv: FloatArray,
    n_steps: int,
    *,
    kernel_scale: FloatArray | None = None,
    regularization: float | None = None,
    affine: bool = True,
    boundary_taper: bool = True,
    smoothing: FloatArray | None = None,
) -> tuple[ComposedDeformation, list[ThinPlateFitInfo]]:
    """Split a large landmark displacement into ``n_steps`` thin-plate steps and compose them.

    Step j moves the landmarks from their current positions a fraction
    1/(n_steps − j) of the way to Q (straight landmark paths), so the
    composition takes P to Q exactly (with ε = 0) while every step is a small
    deformation, close to the identity; a composition of bijections is a
    bijection. One step is :func:`thin_plate_registration` itself.

    Parameters
    ----------
    source_uv, target_uv : (m, 2) float64
        Landmarks P and Q.
    n_steps : int
        Number of steps, ≥ 1.
    kernel_scale, regularization, affine, boundary_taper, smoothing
        As in :func:`thin_plate_registration`, for every step (the centres
        are the landmarks' current positions; with ``smoothing``, each step is
        smoothed towards its goal, so the composition no longer reaches Q).

    Returns
    -------
    deformation : ComposedDeformation
    infos : list of ThinPlateFitInfo
        One per step.
    """
    if n_steps < 1:
        raise ValueError(f"n_steps must be ≥ 1, got {n_steps}")
    P = np.asarray(source_uv, dtype=np.float64)
    Q = np.asarray(target_uv, dtype=np.float64)
    steps: list[ThinPlateDeformation] = []
    infos: list[ThinPlateFitInfo] = []
    cur = P.copy()
    for j in range(n_steps):
        goal = cur + (Q - cur) / (n_steps - j)
        d, info = thin_plate_registration(
            cur,
            goal,
            kernel_scale=kernel_scale,
            regularization=regularization,
            affine=affine,
            boundary_taper=boundary_taper,
            smoothing=smoothing,
        )
        steps.append(d)
        infos.append(info)
        cur = d.apply(cur)
    return ComposedDeformation(tuple(steps)), infos
