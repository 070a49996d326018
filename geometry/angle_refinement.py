"""Angle refinement of a planar map: one reweighted Gauss–Newton step on corner angles."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ._typing import BoolArray, FloatArray, IntArray
from .angle_distortion import corner_edge_products

#: Conjugate-gradient iterations of the refinement's Gauss–Newton step.
#: Measured on ``choi_human_face`` (17k vertices; mean angle distortion of the
#: harmonic disk map 1.2098°): 2 iterations give 1.1961°, 3 give 1.1940°, 4 give
#: 1.1922°, 8 give 1.1897°; subdivided once (68k, 0.6062°): 0.6032°, 0.6027°,
#: 0.6024°, 0.6017°. The step's fixed cost (angles, Jacobian, line search) is
#: about 40 ms at 17k and each iteration about 5 ms: 4 keep the fast map within
#: igl.lscm's time (``benchmarks/bench_disk_map.py``).
ANGLE_REFINE_CG_ITERATIONS = 4

#: Floor (radians) of the absolute angle residual in the ℓ1 reweighting
#: ``w = 1 / max(|r|, floor)``. Smaller floors weight the already-exact
#: corners more; on ``choi_human_face`` 0.1 gave 1.1929°, 0.03 gave 1.1914°,
#: 0.01 gave 1.1895° and 0.003 gave 1.1889° (8 iterations): below 0.01 the gain
#: is in the fourth digit.
ANGLE_REFINE_L1_FLOOR = 1e-2

#: Mean angle error (radians) below which the angles are exact to round-off and
#: no step is taken: the step would only be the round-off's image in the
#: similarity moves that leave every angle unchanged.
_EXACT = 1e-12


@dataclass(frozen=True)
class AngleRefinementInfo:
    """Diagnostics of :func:`refine_angles`.

    Attributes
    ----------
    mean_error_before, mean_error_after : float
        Mean absolute corner-angle error ``|α(uv) − β|`` in degrees before and
        after (equal when the step was rejected).
    cg_iterations : int
        Conjugate-gradient iterations run.
    step : float
        Accepted step length along the Gauss–Newton direction (0 when every
        trial step flipped a triangle or did not lower the error).
    halvings : int
        Step halvings the line search made.
    """

    mean_error_before: float
    mean_error_after: float
    cg_iterations: int
    step: float
    halvings: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


def signed_corner_angles(uv: FloatArray, F: IntArray) -> FloatArray:
    """Signed corner angles of a planar map.

    Parameters
    ----------
    uv : (n, 2) float64
    F : (m, 3) int64

    Returns
    -------
    alpha : (m, 3) float64
        Radians in (−π, π]; ``alpha[f, k]`` at ``F[f, k]``, from edge
        (k→k+1) to edge (k→k+2), positive for a counter-clockwise triangle and
        negative for a flipped one (unlike
        :func:`conformorph.geometry.angle_distortion.corner_angles`, which is unsigned).
    """
    _, cross, dot = corner_edge_products(uv, F)
    return np.asarray(np.arctan2(cross[:, None], dot), dtype=np.float64)


def _angle_jacobian(E: FloatArray, F: IntArray, n: int) -> sp.csr_array:
    """Jacobian of the signed corner angles by the map's coordinates.

    Parameters
    ----------
    E : (m, 3, 2) float64
        Edge vectors from :func:`conformorph.geometry.angle_distortion.corner_edge_products`.
    F : (m, 3) int64
    n : int
        Vertex count.

    Returns
    -------
    J : (3m, 2n) csr_array
        Row ``3f + k`` (the angle at ``F[f, k]``), column ``2v + d``.

    Notes
    -----
    The angle at corner k is ``arg b − arg a`` with ``a = E_k``,
    ``b = −E_{k−1}``, and ``∇ arg z = (−z_y, z_x) / |z|² =: g(z)``, so
    ∂/∂u_{k+1} = −g(E_k), ∂/∂u_{k+2} = −g(E_{k−1}) and ∂/∂u_k is minus their
    sum (angles are invariant to translation).
    """
    g = np.zeros_like(E)
    inv_len2 = 1.0 / (E[..., 0] ** 2 + E[..., 1] ** 2)
    g[..., 0] = -E[..., 1] * inv_len2
    g[..., 1] = E[..., 0] * inv_len2
    g_prev = g[:, [2, 0, 1]]
    G = np.zeros(F.shape + (3, 2))
    G[:, :, 0] = g + g_prev
    G[:, :, 1] = -g
    G[:, :, 2] = -g_prev
    cols = 2 * F[:, [0, 1, 2, 1, 2, 0, 2, 0, 1]].astype(np.int32)  # (m, 9): corner k, j
    xy = np.zeros(cols.shape + (2,), dtype=np.int32)
    xy[..., 0] = cols
    xy[..., 1] = cols + 1
    indptr = np.arange(0, xy.size + 1, 6, dtype=np.int32)
    return sp.csr_array((G.reshape(-1), xy.reshape(-1), indptr), shape=(F.size, 2 * n))


def _dot(a: FloatArray, b: FloatArray) -> float:
    """Inner product without BLAS: on a busy machine OpenBLAS's threads for a
    34k-long ``ddot`` were measured to cost milliseconds, the summation
    microseconds."""
    return float(np.einsum("i,i->", a, b))


def refine_angles(
    uv: FloatArray,
    F: IntArray,
    target_angles: FloatArray,
    free: BoolArray,
    *,
    cg_iterations: int = ANGLE_REFINE_CG_ITERATIONS,
    l1_floor: float = ANGLE_REFINE_L1_FLOOR,
    max_halvings: int = 8,
) -> tuple[FloatArray, AngleRefinementInfo]:
    """Move the free vertices of a planar map to bring its angles nearer targets.

    One iteratively-reweighted Gauss–Newton step on the corner-angle residual
    ``r = α(uv) − β``, towards the minimum of ``Σ |r|`` (the mean angle
    distortion that :func:`conformorph.geometry.angle_distortion` reports), kept
    injective by the line search.

    Parameters
    ----------
    uv : (n, 2) float64
        A map with every triangle counter-clockwise (no flips).
    F : (m, 3) int64
        Triangles.
    target_angles : (m, 3) float64
        Target corner angles β in radians, ``target_angles[f, k]`` at
        ``F[f, k]`` (e.g. :func:`conformorph.geometry.angle_distortion.corner_angles` of
        the surface).
    free : (n,) bool
        Vertices that may move; the others (e.g. the boundary on the unit
        circle) stay where they are.
    cg_iterations : int
        Jacobi-preconditioned conjugate-gradient iterations for the step.
    l1_floor : float
        Floor (radians) of ``|r|`` in the ℓ1 weights ``w = 1 / max(|r|, floor)``.
    max_halvings : int
        Step halvings before the step is rejected.

    Returns
    -------
    uv : (n, 2) float64
        The refined map (a new array); the input map when the step was
        rejected. No triangle is flipped.
    info : AngleRefinementInfo

    Raises
    ------
    ValueError
        If shapes disagree, a parameter is out of range, or the input map
        has a flipped or degenerate triangle.

    Notes
    -----
    The weighted normal equations ``Jᵀ W J δ = −Jᵀ W r`` (J the 3m × 2n
    Jacobian of the corner angles restricted to the free vertices, W the ℓ1
    weights) are solved inexactly by ``cg_iterations`` steps of conjugate
    gradients from δ = 0, preconditioned by the mean of each vertex's two
    diagonal entries of ``Jᵀ W J`` (invariant to rotating the map), the
    truncated-Newton (Steihaug) choice: every CG iterate is a descent
    direction of the weighted model, and the few iterations act on the
    smooth, long-range part of the error that the cotangent (harmonic) map
    leaves. The step is halved until no triangle flips and ``Σ |r|`` falls;
    after ``max_halvings`` halvings the map is returned unchanged. Corner
    angles, hence the result, are invariant to translating, rotating and
    scaling ``uv`` and to the vertex order.

    This is the discrete analogue of angle-based flattening's objective
    (A. Sheffer, E. de Sturler, "Parameterization of faceted surfaces for
    meshing using angle-based flattening", Eng. Comput. 17, 2001), here in
    vertex positions rather than angle variables, so the map stays a valid
    triangulation at every accepted step; the Gauss–Newton/IRLS step follows
    J. Nocedal, S. Wright, "Numerical Optimization", ch. 7 and 10.
    """
    uv = np.asarray(uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    beta = np.asarray(target_angles, dtype=np.float64)
    free = np.asarray(free, dtype=bool)
    n = uv.shape[0]
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ValueError(f"uv must have shape (n, 2), got {uv.shape}")
    if beta.shape != F.shape:
        raise ValueError(f"target_angles must have the faces' shape {F.shape}, got {beta.shape}")
    if free.shape != (n,):
        raise ValueError(f"free must have shape ({n},), got {free.shape}")
    if cg_iterations < 1 or max_halvings < 0 or not l1_floor > 0:
        raise ValueError("cg_iterations must be ≥ 1, max_halvings ≥ 0 and l1_floor > 0")
    E, cross, dot = corner_edge_products(uv, F)
    if np.any(cross <= 0):
        raise ValueError("refine_angles needs a map without flipped or degenerate triangles")

    r = (np.arctan2(cross[:, None], dot) - beta).reshape(-1)
    before = float(np.abs(r).mean())
    if before <= _EXACT:
        return uv.copy(), AngleRefinementInfo(np.degrees(before), np.degrees(before), 0, 0.0, 0)
    w = 1.0 / np.maximum(np.abs(r), l1_floor)
    J = _angle_jacobian(E, F, n)
    delta, done = _weighted_gauss_newton_step(J, w, r, free, cg_iterations)
    found = _injective_halving(uv, delta.reshape(n, 2), F, beta, before, max_halvings)
    if found is not None:
        trial, after, step, halving = found
        return trial, AngleRefinementInfo(
            np.degrees(before), np.degrees(after), done, step, halving
        )
    info = AngleRefinementInfo(np.degrees(before), np.degrees(before), done, 0.0, max_halvings)
    return uv.copy(), info


def _weighted_gauss_newton_step(
    J: sp.csr_array, w: FloatArray, r: FloatArray, free: BoolArray, cg_iterations: int
) -> tuple[FloatArray, int]:
    """Truncated CG on ``Jᵀ W J δ = −Jᵀ W r`` over the free coordinates, from δ = 0.

    Parameters
    ----------
    J : (3m, 2n) csr_array
        Jacobian of the corner angles.
    w : (3m,) float64
        ℓ1 weights.
    r : (3m,) float64
        Angle residuals.
    free : (n,) bool
    cg_iterations : int

    Returns
    -------
    delta : (2n,) float64
        The step (zero at fixed vertices), interleaved x, y.
    iterations : int
        CG iterations done.
    """
    n = free.shape[0]
    mask = np.repeat(free, 2).astype(np.float64)  # fixed vertices' coordinates stay
    J2 = sp.csr_array((J.data**2, J.indices, J.indptr), shape=J.shape)
    # per-vertex preconditioner: the trace of the 2×2 diagonal block of JᵀWJ,
    # which, unlike its x and y entries, does not depend on how the map is rotated
    diag = mask * np.repeat((J2.T @ w).reshape(n, 2).mean(axis=1), 2)
    inv_diag = np.divide(1.0, diag, out=np.zeros_like(diag), where=diag > 0)
    delta = np.zeros(2 * n)
    res = -mask * (J.T @ (w * r))
    z = res * inv_diag
    p = z.copy()
    rz = _dot(res, z)
    done = 0
    for _ in range(cg_iterations):
        if rz <= 0.0:
            break
        Ap = mask * (J.T @ (w * (J @ p)))
        pAp = _dot(p, Ap)
        if pAp <= 0.0:
            break
        a = rz / pAp
        delta += a * p
        res -= a * Ap
        z = res * inv_diag
        rz_new = _dot(res, z)
        p = z + (rz_new / rz) * p
        rz = rz_new
        done += 1
    return delta, done


def _injective_halving(
    uv: FloatArray,
    d: FloatArray,
    F: IntArray,
    beta: FloatArray,
    before: float,
    max_halvings: int,
) -> tuple[FloatArray, float, float, int] | None:
    """Halve the step ``d`` (n, 2) until no triangle flips and the mean ``|α − β|`` falls
    below ``before``: the map, its mean residual, the step and the halvings; None if
    ``max_halvings`` halvings do not get there."""
    step = 1.0
    for halving in range(max_halvings + 1):
        trial = uv + step * d
        _, cross, dot = corner_edge_products(trial, F)
        if np.all(cross > 0):
            after = float(np.abs(np.arctan2(cross[:, None], dot) - beta).mean())
            if after < before:
                return trial, after, step, halving
        step *= 0.5
    return None


__all__ = [
    "ANGLE_REFINE_CG_ITERATIONS",
    "ANGLE_REFINE_L1_FLOOR",
    "AngleRefinementInfo",
    "refine_angles",
    "signed_corner_angles",
]
