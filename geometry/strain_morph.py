"""2D morphing by strain-field interpolation (Yan, Hu and Martin 2004).

Pipeline of the paper's "main steps": (1) remove the rigid motion between
source and target with two reference points A, B; (2) compute the final
strain field ε^n (eq. 1); (3) interpolate it in time (eq. 2 or 3); (4) for
each frame solve φ(V) = 0 (eq. 9), the stationarity condition of
W = ½ ∫ |ε'(V) − ε^t|² dΩ (eq. 4), by Newton–Raphson with the tangent matrix
K (eq. 10–11), warm-started from the previous frame, with the continuation
method of eq. (12) when a plain Newton step would flip a triangle; (5) put
the interpolated rigid motion back.

Choices where the paper is silent (a numerical analyst's defaults)
------------------------------------------------------------------
* **Gauge.** The three rigid degrees of freedom are fixed on two *mesh
  vertices* a (both coordinates) and b (its y coordinate) after moving a to
  the origin and b onto the +x axis. W is invariant under rigid motions, so
  the solution for any other choice of fixed points is a rigid motion of this
  one; the reference points A, B (anywhere inside the source shape, followed
  through every frame by their barycentric coordinates) are then used, exactly
  as in the paper, to put the interpolated rotation and translation back.
  b is the vertex farthest from a, which keeps K well conditioned.
* **Stopping rule.** ``‖V_{l+1} − V_l‖_F < δ`` with δ *relative* to the
  bounding-box diagonal of the source (the paper's δ is absolute), so the
  result does not depend on units.
* **When continuation is used.** A plain Newton step is rejected when it
  would flip (or collapse) a triangle, or when Newton has not converged within
  ``max_iterations``; the frame is then redone from the warm start with the
  continuation of eq. (12) for N = 2, 4, 8, … ``max_continuation``. If that
  fails too, the time step is halved (the paper: "insert more frames") up to
  ``max_substeps`` times; the inserted frames are only used as warm starts.
* **Eq. (12).** Read as the Newton homotopy ``φ(V) − (1 − l/N) φ(V^{t−1})``
  with ``φ`` the residual of the *new* frame and ``V^{t−1}`` the warm start
  (whose homotopy solution at l = 0 is exactly the warm start): one Newton step
  per level l = 1 … N−1, then plain Newton.
* **When eq. (3) fails.** On the compatible letter meshes (I → L, L → T,
  C → S with the corner rule's anchors, since replaced by the letters' stroke
  ends: shears |γ| up to ~13, stretches up to ~10) eq. (3) in the fixed x/y
  frame prescribes, per triangle, a realisable strain at every t, but the
  path of minimisers of W folds a triangle (about t = 0.72 on I → L): every
  frame after that ends ``"flip"`` with the last unflipped iterate kept,
  although W = 0 at t = 1 (the target). Continuation up to N = 64, eight
  halvings of the time step, and (tried, not kept) a backtracking step that
  halves ΔV until no triangle flips do not change this: it is the energy's
  path, not the solver. ``scheme="principal"`` (eq. 3 in each triangle's
  principal frame) converges on I → L and L → T; C → S converges only with
  eq. (2). Nothing here switches scheme silently: ``info.stop_reasons``
  reports it, and :mod:`pipelines.morph2d_pipeline` records any switch in
  ``metrics.json`` (``interp_fallback``).
* **Tangent matrix.** K of eq. (10) is the exact Hessian of W; it is
  factorised with :func:`geometry.sparse_factor.factorize` (LDLᵀ), which
  raises on a singular solve.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .flipped_triangles import max_orientation_step
from .green_lagrange_strain import (
    StrainScheme,
    deformation_gradient,
    interpolate_strain,
    shape_function_gradients,
    strain_from_gradient,
)
from .mesh_errors import NotTrianglesError, SingularSystemError
from .point_location import locate_points
from .sparse_factor import factorize
from .tolerances import (
    STRAIN_BARRIER_FRACTION,
    STRAIN_BARRIER_WEIGHT,
    STRAIN_MAX_TIME_STEP,
    STRAIN_NEWTON_STEP_RTOL,
)

Predictor = Literal["previous", "linear"]
Solver = Literal["barrier", "newton"]


def prescribed_area_ratio(eps: FloatArray) -> FloatArray:
    """Area ratio ``det J = sqrt(det(I + 2E))`` that a strain prescribes, per triangle.

    Parameters
    ----------
    eps : (m, 3) float64
        ``[ε_x, ε_y, γ_xy]``.

    Returns
    -------
    (m,) float64
        Positive; a strain no deformation realises (``det(I + 2E) ≤ 0``, which eq. 3
        can prescribe mid-way) gets the floor 1e-3.

    Examples
    --------
    >>> import numpy as np
    >>> prescribed_area_ratio(np.array([[1.5, 0.0, 0.0], [0.0, 0.0, 0.0]])).tolist()
    [2.0, 1.0]
    """
    det_c = (1.0 + 2.0 * eps[:, 0]) * (1.0 + 2.0 * eps[:, 1]) - eps[:, 2] ** 2
    return np.asarray(np.sqrt(np.maximum(det_c, 1e-6)), dtype=np.float64)


@dataclass(frozen=True)
class StrainMorphInfo:
    """Diagnostics of :func:`strain_morph`, one entry per requested time.

    Attributes
    ----------
    times : (T,) float64
        The times of the returned frames.
    iterations : (T,) int64
        Newton iterations spent on each frame, continuation levels and
        inserted sub-steps included (0 for t = 0).
    continuation : (T,) int64
        Largest continuation level N used (eq. 12); 1 means plain Newton.
    substeps : (T,) int64
        Extra time steps inserted before the frame because continuation alone
        failed.
    step_norms : (T,) float64
        Last Newton update ‖ΔV‖_F relative to the bounding-box diagonal.
    energies : (T,) float64
        W (eq. 4) at the solution, relative to the source area.
    min_jacobian : (T,) float64
        Smallest det J (area ratio) over the triangles of each frame; > 0
        means no triangle is flipped.
    stop_reasons : tuple of str
        Per frame: ``"converged"``, ``"max_iterations"`` (best iterate kept),
        ``"flip"`` (every strategy would flip a triangle; the last unflipped
        iterate is kept) or ``"budget"`` (``max_total_iterations`` was spent before
        the frame was solved; the last state solved is repeated).
    rotation : float
        R, the angle from A⁰B⁰ to AⁿBⁿ in (−π, π].
    translation : (2,) float64
        T, the vector from A⁰ to Aⁿ.
    seconds : float
        Wall-clock time of the whole solve.
    """

    times: FloatArray
    iterations: IntArray
    continuation: IntArray
    substeps: IntArray
    step_norms: FloatArray
    energies: FloatArray
    min_jacobian: FloatArray
    stop_reasons: tuple[str, ...]
    rotation: float
    translation: FloatArray
    seconds: float

    @property
    def converged(self) -> bool:
        """Whether every frame converged."""
        return all(r == "converged" for r in self.stop_reasons)


def _rotation(theta: float) -> FloatArray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def _wrap_angle(theta: float) -> float:
    """Angle in (−π, π]."""
    w = float(np.mod(theta + np.pi, 2.0 * np.pi) - np.pi)
    return np.pi if w == -np.pi else w


def _to_gauge(X: FloatArray, a: int, b: int) -> FloatArray:
    d = X[b] - X[a]
    return (X - X[a]) @ _rotation(-float(np.arctan2(d[1], d[0]))).T


class _StrainSystem:
    """Residual φ (eq. 9) and tangent K (eq. 10) on a fixed mesh, pattern precomputed."""

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
        return deformation_gradient(self.dN, X, self.F)

    def det(self, X: FloatArray) -> FloatArray:
        J = self.jacobians(X)
        return np.asarray(J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0], dtype=np.float64)

    def energy(self, X: FloatArray, eps_t: FloatArray) -> float:
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


@dataclass
class _FrameResult:
    X: FloatArray
    iterations: int
    continuation: int
    step: float
    reason: str


def _max_positive_step(system: _StrainSystem, X: FloatArray, D: FloatArray) -> float:
    """Largest α with det J(X + s D) > 0 on every triangle for all s < α."""
    return max_orientation_step(system.jacobians(X), deformation_gradient(system.dN, D, system.F))


def _barrier_newton(
    system: _StrainSystem,
    X0: FloatArray,
    eps_t: FloatArray,
    d_star: FloatArray,
    tol: float,
    max_iterations: int,
) -> _FrameResult:
    """Minimise W (eq. 4) plus the orientation barrier by a safeguarded Newton method.

    Each step solves ``(K + H_b + μ I) ΔV = −(φ + g_b)`` (eq. 10–11 with the
    barrier's Hessian H_b and gradient g_b; μ = 0 unless K + H_b is singular or
    the step is not a descent direction, then raised tenfold from
    ``1e-8 · max diag``), then backtracks from the largest step that keeps every
    triangle positive until the energy decreases (Armijo); every iterate is
    unflipped.
    """
    w, s0 = STRAIN_BARRIER_WEIGHT, STRAIN_BARRIER_FRACTION

    def total(X: FloatArray) -> float:
        b, _, _ = system.barrier(X, d_star, w, s0, 0)
        return system.energy(X, eps_t) + b if np.isfinite(b) else float("inf")

    X = X0.copy()
    E = total(X)
    if not np.isfinite(E):
        return _FrameResult(X, 0, 1, np.inf, "flip")
    step = np.inf
    for it in range(1, max_iterations + 1):
        _, g_b, H_b = system.barrier(X, d_star, w, s0, 2)
        assert g_b is not None and H_b is not None
        g, K = system.tangent(X, eps_t, (g_b, H_b))
        delta = None
        mu = 0.0
        scale = float(np.abs(K.diagonal()).max()) or 1.0
        for _ in range(8):
            A = K if mu == 0.0 else K + sp.diags_array(np.full(K.shape[0], mu)).tocsc()
            try:
                cand = -factorize(A, symmetric=True).solve(g)
            except SingularSystemError:
                cand = None
            if cand is not None and float(g @ cand) < 0.0:
                delta = cand
                break
            mu = 1e-8 * scale if mu == 0.0 else 10.0 * mu
        if delta is None:
            delta = -g / scale
        D = np.zeros_like(X)
        D.reshape(-1)[system.free] = delta
        full = float(np.linalg.norm(delta))
        if full < tol and np.min(system.det(X + D)) > 0.0:
            # the Newton increment itself meets the stopping rule: near the minimum
            # the energy is flat to round-off and Armijo's test cannot tell a decrease
            # (a warm start already at the solution ended "max_iterations")
            return _FrameResult(X + D, it, 1, full, "converged")
        alpha = min(1.0, 0.9 * _max_positive_step(system, X, D))
        slope = float(g @ delta)
        while alpha > 1e-12:
            Xn = X + alpha * D
            En = total(Xn)
            if En <= E + 1e-4 * alpha * slope:
                break
            alpha *= 0.5
        else:
            return _FrameResult(X, it, 1, step, "max_iterations")
        step = float(alpha * np.linalg.norm(delta))
        X, E = Xn, En
        if step < tol:
            return _FrameResult(X, it, 1, step, "converged")
    return _FrameResult(X, max_iterations, 1, step, "max_iterations")


def _newton(
    system: _StrainSystem,
    X0: FloatArray,
    eps_t: FloatArray,
    N: int,
    tol: float,
    max_iterations: int,
) -> _FrameResult:
    """Newton from X0; the first N−1 steps follow the homotopy of eq. (12)."""
    X = X0.copy()
    r0 = system.residual(X0, eps_t) if N > 1 else None
    step = np.inf
    for it in range(1, max_iterations + 1):
        phi, K = system.tangent(X, eps_t)
        if r0 is not None and it < N:
            phi = phi + (it / N - 1.0) * r0  # eq. (12)
        try:
            delta = -factorize(K, symmetric=True).solve(phi)  # eq. (11)
        except SingularSystemError:
            return _FrameResult(X, it, N, step, "flip")
        Xn = X.copy()
        Xn.reshape(-1)[system.free] += delta
        if np.min(system.det(Xn)) <= 0.0:
            return _FrameResult(X, it, N, step, "flip")
        step = float(np.linalg.norm(delta))
        X = Xn
        if it >= N and step < tol:
            return _FrameResult(X, it, N, step, "converged")
    return _FrameResult(X, max_iterations, N, step, "max_iterations")


def strain_morph(
    source_V: FloatArray,
    target_V: FloatArray,
    F: IntArray,
    times: FloatArray,
    *,
    scheme: StrainScheme = "modified",
    reference_points: FloatArray | None = None,
    tol: float = STRAIN_NEWTON_STEP_RTOL,
    max_iterations: int = 30,
    max_continuation: int = 64,
    max_substeps: int = 8,
    max_time_step: float = STRAIN_MAX_TIME_STEP,
    predictor: Predictor = "linear",
    solver: Solver = "barrier",
    max_total_iterations: int | None = None,
) -> tuple[FloatArray, StrainMorphInfo]:
    """Intermediate shapes between two compatible planar meshes by strain-field interpolation.

    Parameters
    ----------
    source_V : (n, 2) float64
        Source vertex positions (t = 0).
    target_V : (n, 2) float64
        Target vertex positions (t = 1); vertex i corresponds to vertex i.
    F : (m, 3) int64
        Shared triangles, counter-clockwise in ``source_V``.
    times : (T,) float64
        Non-decreasing times in [0, 1] at which frames are wanted.
    scheme : {"modified", "linear", "principal"}, optional
        Strain interpolation: eq. (3) (default), eq. (2), or eq. (3) in each
        triangle's principal frame (see
        :func:`geometry.green_lagrange_strain.interpolate_strain`).
    reference_points : (2, 2) float64, optional
        A⁰ (translation reference) and B⁰ (rotation reference), two distinct
        points inside the source shape; their target positions Aⁿ, Bⁿ are
        their images under the piecewise-linear map source → target. Default:
        the vertex nearest the centroid and the vertex farthest from it.
    tol : float, optional
        δ of the stopping rule ``‖V_{l+1} − V_l‖_F < δ``, relative to the
        bounding-box diagonal of the source.
    max_iterations : int, optional
        Newton iterations allowed per attempt at one frame.
    max_continuation : int, optional
        Largest N of the continuation method (eq. 12); N doubles from 2.
    max_substeps : int, optional
        How often a time step may be halved when continuation fails.
    max_time_step : float, optional
        Largest time step the solver takes: between two requested times
        further apart, evenly spaced intermediate frames are solved as warm
        starts and not returned (their iterations and substeps count towards
        the next requested frame). A coarse frame request must not decide the
        solver's path: with 5 frames the stick figures' path jumped to another
        branch of W's minimisers and ended 0.8 % of the target's size from it,
        with steps of at most 1/60 it reaches the target
        (``STRAIN_MAX_TIME_STEP``).
    solver : {"barrier", "newton"}, optional
        ``"newton"``: the paper's Newton–Raphson on φ(V) = 0 (eq. 9–11) with the
        continuation of eq. (12), a step that would flip a triangle refused.
        ``"barrier"`` (default): W (eq. 4) plus an orientation barrier that is zero
        while every triangle keeps 70 % of the area ratio its interpolated strain
        prescribes (``STRAIN_BARRIER_FRACTION``), minimised by a safeguarded Newton
        method (the same K of eq. 10, shifted when indefinite, and a line search that
        never leaves the unflipped meshes). Green–Lagrange strain cannot tell a
        triangle from its mirror image, so the minimisers of W alone may fold a
        triangle mid-way (I → L, L → T, C → S with eq. 3), where Newton then stalls;
        the barrier keeps the path on the unfolded side. Where it is inactive
        (every frame of the bar pair, and t = 1 whenever the target is reached) the
        frames are eq. (9)'s exactly. It can also hold a frame in a local minimum:
        S → U with the corner rule's anchors, eq. (2), solved at t = 1 from the frame
        at t = 59/60 with 600 iterations allowed, ended ``"converged"`` with 73
        triangles under the threshold, 0.13 of the size from the target, where a
        plain Newton step would flip a triangle (measured with the barrier at 25 %
        of the prescribed area, before it moved to 70 %; not re-measured since).
    predictor : {"linear", "previous"}, optional
        Warm start: the previous frame (the paper) or its linear extrapolation
        from the two previous frames (default; about one Newton iteration fewer
        per frame, and the previous frame is used whenever the extrapolation
        would flip a triangle).
    max_total_iterations : int, optional
        Newton iterations allowed for the whole call (default: no limit). Checked
        before every attempt at a frame or an inserted sub-step: once spent, nothing
        more is solved; the frame in progress ends ``"budget"`` and, like every
        later frame (also ``"budget"``), repeats the last state solved. Bounds
        the time of a hopeless morph: on S → U with the corner rule's anchors (1250
        vertices) eq. (3) in the principal frame spent 840 s (2 shared cores) without
        reaching the target, while the morphs of ``benchmarks/bench_morph2d.py`` that
        converge (61 frames; horse → heart not run) spend 121 (annulus) to 1173
        iterations (stick figures, eq. 2).

    Returns
    -------
    frames : (T, n, 2) float64
        Vertex positions of every frame, rigid motion restored: A and B move
        by the interpolated translation ``T_{A⁰} + t T`` and rotation
        ``R_{A⁰B⁰} + t R`` (R in (−π, π]). ``frames[0]`` is the source when
        ``times[0] == 0``, ``frames[-1]`` the target (to the solver tolerance)
        when ``times[-1] == 1``.
    info : StrainMorphInfo
        Per-frame Newton diagnostics.

    Raises
    ------
    NotTrianglesError, ZeroAreaFaceError
        Bad arrays, or a source triangle that is degenerate or clockwise.
    ValueError
        Mismatched shapes, a non-monotone or out-of-range ``times``, or
        reference points outside the source mesh or coincident.

    Notes
    -----
    The unknowns are the 2n vertex coordinates minus the three fixed by the
    gauge (see the module docstring); each Newton step solves
    ``K_l (V_{l+1} − V_l) = −φ(V_l)`` (eq. 11) with a fresh LDLᵀ factorisation
    of the sparse (2n−3)² matrix K (eq. 10). A step that would give any
    triangle a non-positive Jacobian determinant is never taken.

    References
    ----------
    H.-B. Yan, S.-M. Hu, R. R. Martin, "Morphing based on strain field
    interpolation", Computer Animation and Virtual Worlds 15 (2004) 443–452,
    doi:10.1002/cav.48.
    """
    start = time.perf_counter()
    source_V = np.asarray(source_V, dtype=np.float64)
    target_V = np.asarray(target_V, dtype=np.float64)
    F = np.asarray(F)
    if source_V.ndim != 2 or source_V.shape[1] != 2:
        raise NotTrianglesError(f"source_V must have shape (n, 2), got {source_V.shape}")
    if target_V.shape != source_V.shape:
        raise ValueError(f"target_V has shape {target_V.shape}, expected {source_V.shape}")
    if not (np.all(np.isfinite(source_V)) and np.all(np.isfinite(target_V))):
        raise ValueError("vertex positions must be finite")
    times = np.asarray(times, dtype=np.float64).reshape(-1)
    if times.size == 0 or times.min() < 0.0 or times.max() > 1.0 or np.any(np.diff(times) < 0):
        raise ValueError("times must be a non-empty, non-decreasing sequence in [0, 1]")
    if max_iterations < 1 or max_continuation < 1 or max_substeps < 0 or not tol > 0:
        raise ValueError("max_iterations, max_continuation must be ≥ 1, max_substeps ≥ 0, tol > 0")
    if not 0.0 < max_time_step <= 1.0:
        raise ValueError(f"max_time_step must be in (0, 1], got {max_time_step}")
    if max_total_iterations is not None and max_total_iterations < 0:
        raise ValueError(f"max_total_iterations must be ≥ 0, got {max_total_iterations}")
    if solver not in ("barrier", "newton"):
        raise ValueError(f"solver must be 'barrier' or 'newton', got {solver!r}")
    if predictor not in ("linear", "previous"):
        raise ValueError(f"predictor must be 'linear' or 'previous', got {predictor!r}")
    n = source_V.shape[0]

    # validates F and the source triangles (ZeroAreaFaceError on a bad one)
    dN, area = shape_function_gradients(source_V, F)
    F = F.astype(np.int64)
    tgt_det = np.linalg.det(deformation_gradient(dN, target_V, F))
    if np.any(tgt_det <= 0):
        raise ValueError(
            f"{int(np.sum(tgt_det <= 0))} triangles are flipped or degenerate in target_V: "
            "the two meshes are not compatible"
        )
    centroid = source_V.mean(axis=0)
    if reference_points is None:
        ia = int(np.argmin(np.linalg.norm(source_V - centroid, axis=1)))
        ib = int(np.argmax(np.linalg.norm(source_V - source_V[ia], axis=1)))
        reference_points = source_V[[ia, ib]]
    ref = np.asarray(reference_points, dtype=np.float64)
    if ref.shape != (2, 2):
        raise ValueError(f"reference_points must have shape (2, 2), got {ref.shape}")
    ref_loc = locate_points(source_V, F, ref)
    ref_face, ref_bary = ref_loc.triangle, ref_loc.barycentric
    if np.any(ref_loc.distance > 1e-9 * float(np.ptp(source_V, axis=0).max())):
        raise ValueError("reference points A, B must lie inside the source shape")
    if np.linalg.norm(ref[1] - ref[0]) <= 1e-12 * np.ptp(source_V, axis=0).max():
        raise ValueError("reference points A and B coincide")

    def follow(X: FloatArray) -> FloatArray:
        return np.asarray(np.einsum("kj,kjd->kd", ref_bary, X[F[ref_face]]), dtype=np.float64)

    A0, B0 = follow(source_V)
    An, Bn = follow(target_V)
    theta0 = float(np.arctan2(*(B0 - A0)[::-1]))
    R = _wrap_angle(float(np.arctan2(*(Bn - An)[::-1])) - theta0)
    T = An - A0

    # gauge vertices: a nearest A, b farthest from a
    a = int(np.argmin(np.linalg.norm(source_V - A0, axis=1)))
    b = int(np.argmax(np.linalg.norm(source_V - source_V[a], axis=1)))
    rest = _to_gauge(source_V, a, b)
    tgt = _to_gauge(target_V, a, b)
    system = _StrainSystem(rest, F, np.array([2 * a, 2 * a + 1, 2 * b + 1]))
    eps_n = strain_from_gradient(system.jacobians(tgt))
    diag = float(np.linalg.norm(np.ptp(source_V, axis=0)))
    abs_tol = tol * diag
    total_area = float(area.sum())

    spent_total = [0]  # Newton iterations of every attempt so far

    def out_of_budget() -> bool:
        return max_total_iterations is not None and spent_total[0] >= max_total_iterations

    def solve_at(t: float, Xw: FloatArray) -> _FrameResult:
        if out_of_budget():
            return _FrameResult(Xw.copy(), 0, 1, np.inf, "budget")
        res = _solve_at(t, Xw)
        spent_total[0] += res.iterations
        return res

    def _solve_at(t: float, Xw: FloatArray) -> _FrameResult:
        eps_t = interpolate_strain(eps_n, t, scheme=scheme)
        if solver == "barrier":
            return _barrier_newton(
                system, Xw, eps_t, prescribed_area_ratio(eps_t), abs_tol, max_iterations
            )
        res = _newton(system, Xw, eps_t, 1, abs_tol, max_iterations)
        spent = res.iterations
        N = 2
        while res.reason != "converged" and N <= max_continuation:
            res = _newton(system, Xw, eps_t, N, abs_tol, max_iterations + N)
            spent += res.iterations
            N *= 2
        res.iterations = spent
        return res

    def advance(t_prev: float, t: float, Xw: FloatArray, depth: int) -> tuple[_FrameResult, int]:
        res = solve_at(t, Xw)
        if res.reason in ("converged", "budget") or depth >= max_substeps:
            return res, 0
        mid = 0.5 * (t_prev + t)
        first, sub1 = advance(t_prev, mid, Xw, depth + 1)
        if first.reason != "converged":
            first.iterations += res.iterations
            return first, sub1 + 1
        second, sub2 = advance(mid, t, first.X, depth + 1)
        second.iterations += res.iterations + first.iterations
        return second, sub1 + sub2 + 1

    def predict(
        prev_X: FloatArray, prev_t: float, older: tuple[FloatArray, float] | None, t: float
    ) -> FloatArray:
        """Warm start at t: the previous frame or its linear extrapolation."""
        if predictor == "linear" and older is not None and prev_t > older[1]:
            w = (t - prev_t) / (prev_t - older[1])
            guess = prev_X + w * (prev_X - older[0])
            if np.min(system.det(guess)) > 0.0:
                return guess
        return prev_X

    T_count = times.shape[0]
    X_all = np.zeros((T_count, n, 2))
    iterations = np.zeros(T_count, dtype=np.int64)
    continuation = np.ones(T_count, dtype=np.int64)
    substeps = np.zeros(T_count, dtype=np.int64)
    step_norms = np.zeros(T_count)
    energies = np.zeros(T_count)
    min_jac = np.zeros(T_count)
    reasons: list[str] = []
    prev_X, prev_t = rest, 0.0
    older: tuple[FloatArray, float] | None = None
    for i, t_i in enumerate(times):
        t = float(t_i)
        if t == 0.0:
            res = _FrameResult(rest.copy(), 0, 1, 0.0, "converged")
            sub = 0
        else:
            # intermediate warm-start frames, so that no step exceeds max_time_step
            k = max(1, int(np.ceil((t - prev_t) / max_time_step - 1e-9)))
            spent = sub = 0
            for j in range(1, k + 1):
                tj = t if j == k else prev_t + (t - prev_t) * j / k
                res, sj = advance(prev_t, tj, predict(prev_X, prev_t, older, tj), 0)
                spent += res.iterations
                sub += sj
                if res.reason == "budget":  # keep the last solved state, not a warm start
                    res = _FrameResult(prev_X.copy(), 0, 1, np.inf, "budget")
                    break
                if j < k:
                    sub += 1
                    older = (prev_X, prev_t)
                    prev_X, prev_t = res.X, tj
            res.iterations = spent
        X_all[i] = res.X
        iterations[i] = res.iterations
        continuation[i] = res.continuation
        substeps[i] = sub
        step_norms[i] = res.step / diag if np.isfinite(res.step) else np.inf
        eps_t = interpolate_strain(eps_n, t, scheme=scheme)
        energies[i] = system.energy(res.X, eps_t) / total_area
        min_jac[i] = float(np.min(system.det(res.X)))
        reasons.append(res.reason)
        if t > prev_t:
            older = (prev_X, prev_t)
        prev_X, prev_t = res.X, t

    # (5) restore the interpolated rigid motion through A and B
    frames = np.zeros_like(X_all)
    for i, t in enumerate(times):
        X = X_all[i]
        At, Bt = follow(X)
        d = Bt - At
        theta = theta0 + float(t) * R - float(np.arctan2(d[1], d[0]))
        frames[i] = (X - At) @ _rotation(theta).T + A0 + float(t) * T

    info = StrainMorphInfo(
        times=times.copy(),
        iterations=iterations,
        continuation=continuation,
        substeps=substeps,
        step_norms=step_norms,
        energies=energies,
        min_jacobian=min_jac,
        stop_reasons=tuple(reasons),
        rotation=R,
        translation=np.asarray(T, dtype=np.float64),
        seconds=time.perf_counter() - start,
    )
    return frames, info
