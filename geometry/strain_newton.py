"""Per-frame solvers of the strain morph: Newton–Raphson (eq. 11) with the
continuation of eq. (12), and the barrier-safeguarded Newton method.

Both minimise W (eq. 4) of a :class:`conformorph.geometry.strain_system.StrainSystem` from a
warm start; neither ever returns a flipped mesh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray
from .flipped_triangles import max_orientation_step
from .green_lagrange_strain import deformation_gradient
from .mesh_errors import SingularSystemError
from .sparse_factor import Factorization
from .strain_system import StrainSystem
from .tolerances import STRAIN_BARRIER_FRACTION, STRAIN_BARRIER_WEIGHT


@dataclass
class FrameResult:
    """One frame's solve: positions and how it ended.

    Attributes
    ----------
    X : (n, 2) float64
        Positions (gauge frame).
    iterations : int
        Newton iterations spent.
    continuation : int
        Continuation level N used (eq. 12); 1 for plain Newton.
    step : float
        Last update ‖ΔV‖_F (absolute; inf when none was taken).
    reason : str
        ``"converged"``, ``"max_iterations"``, ``"flip"``, ``"budget"`` or ``"stalled"``.
    """

    X: FloatArray
    iterations: int
    continuation: int
    step: float
    reason: str


def max_positive_step(system: StrainSystem, X: FloatArray, D: FloatArray) -> float:
    """Largest α with det J(X + s D) > 0 on every triangle for all s < α.

    Parameters
    ----------
    system : StrainSystem
    X : (n, 2) float64
        Current positions, every triangle positive.
    D : (n, 2) float64
        Step direction.

    Returns
    -------
    float
        inf when no triangle's determinant ever reaches 0 along the ray.
    """
    return max_orientation_step(system.jacobians(X), deformation_gradient(system.dN, D, system.F))


def _shifted_newton_direction(
    system: StrainSystem, X: FloatArray, eps_t: FloatArray, barrier: tuple[FloatArray, FloatArray]
) -> tuple[FloatArray, FloatArray, Factorization | None]:
    """Gradient g and step ``−(K + H_b + μ I)⁻¹ g`` (μ raised tenfold from ``1e-8 · max diag``
    until the step descends; ``−g / max diag`` if none does), and the factorisation used."""
    g, K, U = system.tangent_upper(X, eps_t, barrier)
    mu = 0.0
    scale = float(np.abs(K.data[system.diag_full]).max()) or 1.0
    for _ in range(8):
        try:
            fac = system.factorize(K, U, mu)
            cand = -fac.solve(g)
        except SingularSystemError:
            cand = None
        if cand is not None and float(g @ cand) < 0.0:
            return g, cand, fac
        mu = 1e-8 * scale if mu == 0.0 else 10.0 * mu
    return g, -g / scale, None


def barrier_newton(
    system: StrainSystem,
    X0: FloatArray,
    eps_t: FloatArray,
    d_star: FloatArray,
    tol: float,
    max_iterations: int,
    *,
    reuse_factor: bool = False,
) -> FrameResult:
    """Minimise W (eq. 4) plus the orientation barrier by a safeguarded Newton method.

    Each step solves ``(K + H_b + μ I) ΔV = −(φ + g_b)`` (eq. 10–11 with the
    barrier's Hessian H_b and gradient g_b; μ = 0 unless K + H_b is singular or
    the step is not a descent direction, then raised tenfold from
    ``1e-8 · max diag``), then backtracks from the largest step that keeps every
    triangle positive until the energy decreases (Armijo); every iterate is
    unflipped.

    With ``reuse_factor``, a step taken in full whose increment is under half the
    previous one (Newton converging fast) is followed by a chord step: the new
    gradient solved with the last factorisation, no new K (modified Newton). A
    chord step that does not descend, or that the line search rejects, is
    replaced by a full Newton step; each counts as an iteration.

    Parameters
    ----------
    system : StrainSystem
    X0 : (n, 2) float64
        Warm start, every triangle positive.
    eps_t : (m, 3) float64
        Target strain of the frame (eq. 2 or 3).
    d_star : (m,) float64
        Area ratios the target strain prescribes (:func:`prescribed_area_ratio`).
    tol : float
        Absolute step tolerance δ.
    max_iterations : int
    reuse_factor : bool, optional
        Chord steps where Newton converges fast (default False).

    Returns
    -------
    FrameResult
    """
    w, s0 = STRAIN_BARRIER_WEIGHT, STRAIN_BARRIER_FRACTION

    def total(X: FloatArray) -> float:
        b, _, _ = system.barrier(X, d_star, w, s0, 0)
        return system.energy(X, eps_t) + b if np.isfinite(b) else float("inf")

    X = X0.copy()
    E = total(X)
    if not np.isfinite(E):
        return FrameResult(X, 0, 1, np.inf, "flip")
    step, prev_full = np.inf, np.inf
    fac: Factorization | None = None
    chord = False
    for it in range(1, max_iterations + 1):
        delta = None
        if chord and fac is not None:
            _, g_b, _ = system.barrier(X, d_star, w, s0, 1)
            assert g_b is not None
            g = system.residual(X, eps_t) + system._assemble_vector(g_b)
            try:
                cand = -fac.solve(g)
                delta = cand if float(g @ cand) < 0.0 else None
            except SingularSystemError:
                delta = None
        used_chord = delta is not None
        if delta is None:
            _, g_b, H_b = system.barrier(X, d_star, w, s0, 2)
            assert g_b is not None and H_b is not None
            g, delta, fac = _shifted_newton_direction(system, X, eps_t, (g_b, H_b))
        D = np.zeros_like(X)
        D.reshape(-1)[system.free] = delta
        full = float(np.linalg.norm(delta))
        if full < tol and np.min(system.det(X + D)) > 0.0:
            # the Newton increment itself meets the stopping rule: near the minimum
            # the energy is flat to round-off and Armijo's test cannot tell a decrease
            # (a warm start already at the solution ended "max_iterations")
            return FrameResult(X + D, it, 1, full, "converged")
        alpha = min(1.0, 0.9 * max_positive_step(system, X, D))
        slope = float(g @ delta)
        while alpha > 1e-12:
            Xn = X + alpha * D
            En = total(Xn)
            if En <= E + 1e-4 * alpha * slope:
                break
            alpha *= 0.5
        else:
            if used_chord:  # the old factorisation is too far off: a full step next
                chord = False
                continue
            return FrameResult(X, it, 1, step, "max_iterations")
        step = float(alpha * np.linalg.norm(delta))
        X, E = Xn, En
        if step < tol:
            return FrameResult(X, it, 1, step, "converged")
        chord = reuse_factor and alpha == 1.0 and full < 0.5 * prev_full
        prev_full = full
    return FrameResult(X, max_iterations, 1, step, "max_iterations")


def continuation_newton(
    system: StrainSystem,
    X0: FloatArray,
    eps_t: FloatArray,
    N: int,
    tol: float,
    max_iterations: int,
) -> FrameResult:
    """Newton–Raphson from X0 (eq. 11); the first N−1 steps follow the homotopy of eq. (12).

    Each step solves ``K_l ΔV = −φ(V_l)`` (eq. 11); for l < N the right-hand
    side is ``−(φ(V_l) − (1 − l/N) φ(V⁰))`` (eq. 12). A step that would flip a
    triangle ends the attempt (``"flip"``, the last unflipped iterate kept).

    Parameters
    ----------
    system : StrainSystem
    X0 : (n, 2) float64
        Warm start.
    eps_t : (m, 3) float64
        Target strain of the frame.
    N : int
        Continuation level; 1 is plain Newton.
    tol : float
        Absolute step tolerance δ.
    max_iterations : int

    Returns
    -------
    FrameResult
    """
    X = X0.copy()
    r0 = system.residual(X0, eps_t) if N > 1 else None
    step = np.inf
    for it in range(1, max_iterations + 1):
        phi, K, U = system.tangent_upper(X, eps_t)
        if r0 is not None and it < N:
            phi = phi + (it / N - 1.0) * r0  # eq. (12)
        try:
            delta = -system.factorize(K, U).solve(phi)  # eq. (11)
        except SingularSystemError:
            return FrameResult(X, it, N, step, "flip")
        Xn = X.copy()
        Xn.reshape(-1)[system.free] += delta
        if np.min(system.det(Xn)) <= 0.0:
            return FrameResult(X, it, N, step, "flip")
        step = float(np.linalg.norm(delta))
        X = Xn
        if it >= N and step < tol:
            return FrameResult(X, it, N, step, "converged")
    return FrameResult(X, max_iterations, N, step, "max_iterations")
