"""Non-rigid ICP: a smooth displacement of a source mesh onto a target surface.

Dense correspondences for the disk registration (an extension of the face
morphing paper, whose DMT uses the landmarks only). The landmarks pin the
registration at m points; closest points alone slide where the surface
moves. Here the source vertices are displaced by the smoothest field (in the
bi-Laplacian sense, on the *source surface*, so the upper and lower lip move
independently even where they touch in space) that carries them onto the
target surface and the source landmarks onto the target landmarks, by
alternating closest points and a sparse linear solve, from stiff to supple
(Amberg, Romdhani and Vetter's stiffness annealing, with a bi-Laplacian
regulariser in place of their per-vertex affine stiffness). Each iteration
minimises, over the displacements d (n, 3),

.. math::

    E(d) = \\sum_v \\bar a_v w_v |x_v + d_v - c_v|^2
         + \\alpha\\, d^T L M^{-1} L\\, d / A
         + \\frac{\\beta}{m} \\sum_l \\omega_l \\Big|\\sum_j b_{lj} (x + d)_{t_{lj}} - y_l\\Big|^2

with :math:`c_v` the closest target point of the current :math:`x_v + d_v`,
:math:`\\bar a_v = A_v / A` the source's normalised vertex areas,
:math:`w_v` the caller's weights times the match test (distance below
``max_distance``, normals within ``min_normal_cosine``), L the cotangent
Laplacian (positive semi-definite) and M the vertex areas of the source.
:math:`\\omega_l` are the landmarks' own weights (default 1, e.g. a detector's
confidence) and β may change from stage to stage (``landmark_schedule``: a pull
that fades as the fit becomes supple lets the closest points correct imprecise
landmarks). The three coordinates decouple: one factorisation, three solves.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ._typing import BoolArray, FloatArray, IntArray
from .cotangent_laplacian import cotangent_laplacian
from .mesh_errors import SingularSystemError
from .sparse_factor import (
    Factorization,
    SymmetricRefactorization,
    factorize,
    preconditioned_cg,
)
from .surface_distance import SurfaceDistance, projected_barycentrics
from .vertex_areas import vertex_areas
from .vertex_normals import VertexNormals, vertex_normals
from .vertex_pull import MutualNearestVertices

#: Stiffness α of the closest-point iterations (diameter-normalised surfaces), stiff to
#: supple, one iteration each by default: a decade per step, then three at the supple
#: end. Chosen by measurement on the Table 3 curved ICT sequence
#: (``benchmarks/bench_nicp_variants.py``, DMT/identity at t = 1.3, 1.5): this
#: schedule 1.176, 1.212 in 6 iterations; the earlier half-decade schedule with 3
#: iterations per stage 1.187, 1.240 in 18; one iteration per half decade 1.378,
#: 1.352; going on to 1e-6 1.449, 1.411 (supple fits that fold).
STIFFNESS_SCHEDULE = (1e-3, 1e-4, 1e-5, 3e-6, 3e-6, 3e-6)
#: Relative residual and iteration cap of the CG solves that reuse the previous
#: iteration's factorisation when the stiffness repeats (beyond the cap, or when CG
#: fails, the matrix is factorised afresh).
ICP_CG_RTOL = 1e-10
ICP_CG_MAX_ITERATIONS = 20
#: The bi-Laplacian's lumped mass is floored at this fraction of the mean vertex area.
#: A vertex whose one-ring is tiny (a cluster of small triangles in a clean but
#: unevenly graded mesh: a coarse face model's mouth corner, a decimation's leftover)
#: has (L d)_v / A_v weighted by 1/A_v: at 1e-5 of the mean the regulariser's entries
#: span 10 decades, the factorisation's residual misses the solve's test and the morph
#: stopped ("numerically singular", issue 27) although the problem is well posed. With
#: the floor the energy there is that of a vertex of 1e-3 of the mean area: still a
#: stiff spot, measured unchanged elsewhere; 1e-3 is the area below which the
#: decimation welds triangles (``pipelines.preparation.decimation.WELD_AREA_RTOL``).
ICP_MASS_FLOOR = 1e-3
#: Should a solve still fail, each diagonal entry is raised by this fraction of itself,
#: then by each next value (a scale-free Tikhonov term, strongest where the matrix is
#: stiffest, reported as ``"shift"`` in the history); past the last, the error is raised.
ICP_DIAGONAL_SHIFTS = (1e-10, 1e-8, 1e-6)


@dataclass(frozen=True)
class NonrigidICPResult:
    """Result of :func:`nonrigid_icp`.

    Attributes
    ----------
    deformed : (n, 3) float64
        Displaced source vertices x + d.
    closest : (n, 3) float64
        Their closest points on the target surface.
    distance : (n,) float64
        Distance of every deformed vertex to the target surface.
    triangle : (n,) int64
        Target triangle holding each closest point.
    barycentric : (n, 3) float64
        Barycentric coordinates of the closest point in that triangle.
    matched : (n,) bool
        Vertices that pass the match test at the end (distance, normals).
    history : list of dict
        Per iteration: ``{"stiffness", "rms_distance", "matched", "step",
        "cg_iterations", "shift"}`` (rms over the matched, weighted vertices; largest
        displacement change; CG iterations of a solve preconditioned by the
        previous iteration's factorisation at the same stiffness, 0 when the
        matrix was factorised; the relative diagonal shift of a solve that needed
        one, :data:`ICP_DIAGONAL_SHIFTS`, else 0).
    """

    deformed: FloatArray
    closest: FloatArray
    distance: FloatArray
    triangle: IntArray
    barycentric: FloatArray
    matched: BoolArray
    history: list[dict[str, float]] = field(default_factory=list)


def _face_normals(V: FloatArray, F: IntArray) -> FloatArray:
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    return np.asarray(n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300))


@dataclass(frozen=True)
class ICPLandmarks:
    """Landmarks of a non-rigid ICP: points on the source mesh and where they must go.

    Attributes
    ----------
    triangle : (m,) int64
        Source triangle of every landmark.
    barycentric : (m, 3) float64
        Its barycentric coordinates there.
    target : (m, 3) float64
        The landmarks on the target surface.
    weight : (m,) float64, optional
        Non-negative weight ω_l of every landmark (e.g. its confidence); default 1.
    """

    triangle: IntArray
    barycentric: FloatArray
    target: FloatArray
    weight: FloatArray | None = None


@dataclass(frozen=True)
class NonrigidICPOptions:
    """Schedule and matching thresholds of :func:`nonrigid_icp`.

    Attributes
    ----------
    stiffness : sequence of float
        α of the stages, each run for ``iterations`` iterations. Default
        :data:`STIFFNESS_SCHEDULE`.
    iterations : int
        Closest-point iterations per stage. Default 1.
    landmark_weight : float
        β of the landmark term (relative to the unit total data weight). Default 10.
    landmark_schedule : sequence of float, optional
        β of every stage instead (one per ``stiffness`` value, each ≥ 0), e.g. a
        pull that fades as the fit becomes supple. Default: ``landmark_weight`` at
        every stage.
    landmark_retarget : int, optional
        After this many stages (≥ 1), every landmark's target becomes the closest
        target point of where the fit has carried it: the stiff stages average the
        landmarks' errors, the supple ones stay pinned at the corrected points
        (imprecise landmarks). Default None: the given targets throughout.
    max_distance : float
        Deformed vertices farther than this from the target are not pulled. Default 0.05.
    min_normal_cosine : float
        Nor are those whose normal and the target triangle's disagree more. Default 0.5.
    symmetric : float
        Weight γ ≥ 0 of the symmetric (target → source) matching: every target vertex
        also pulls its closest point on the deformed source towards itself,
        :math:`\\gamma \\sum_j \\bar a^t_j w^t_j |\\sum_k b_{jk} (x + d)_{s_{jk}} - t_j|^2`
        (target vertex areas normalised, the same match test), so that the source
        spreads over the target as the target's own vertices do instead of sliding
        where closest points alone leave it free. Default 0 (closest points only):
        measured on the corpus's tuning split (``benchmarks/face_corpus.py``, exact
        landmarks, per-vertex mean / max mm, γ = 0 → 0.3 → 1): ict_pair_0 0.83 / 6.7 →
        0.78 / 5.9 → 0.74 / 5.8, ict_pair_2 0.54 → 0.52 → 0.49, ict_open60_0 1.28 →
        1.26 → 1.20, meshmonk_warp_0 2.08 → 2.04 → 2.06, but ict_pair_1 1.41 / 10.7 →
        1.80 / 20.5 → 1.87 / 22.7: no weight helps every face, so the default stays 0.
    vertex_pull : float
        Weight g in [0, 1] of the target's own vertices in the correspondences from
        stage ``vertex_pull_from`` on: a source vertex and a target vertex that are each
        other's nearest vertex (within ``max_distance``, normals' cosine at least
        ``vertex_pull_normal_cosine``; :mod:`conformorph.geometry.vertex_pull`) make
        the vertex's correspondence (1 − g) c_v + g t_j instead of its closest point
        c_v. Closest points say nothing about where along the surface a vertex belongs;
        where the meshes sample the surface alike the target's vertices do (MeshMonk's
        push-pull matching). Default 0 (closest points only).
    vertex_pull_from : int
        First stage (0-based) with the vertex pull. Default 3.
    vertex_pull_normal_cosine : float
        Normal test of the vertex pairs. Default 0.9.
    """

    stiffness: Sequence[float] = STIFFNESS_SCHEDULE
    iterations: int = 1
    landmark_weight: float = 10.0
    landmark_schedule: Sequence[float] | None = None
    landmark_retarget: int | None = None
    max_distance: float = 0.05
    min_normal_cosine: float = 0.5
    symmetric: float = 0.0
    vertex_pull: float = 0.0
    vertex_pull_from: int = 3
    vertex_pull_normal_cosine: float = 0.9


def _checked_landmarks(
    landmarks: ICPLandmarks,
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
    lt = np.asarray(landmarks.triangle, dtype=np.int64).ravel()
    lb = np.asarray(landmarks.barycentric, dtype=np.float64)
    ly = np.asarray(landmarks.target, dtype=np.float64)
    m = lt.size
    if lb.shape != (m, 3) or ly.shape != (m, 3) or m == 0:
        raise ValueError(
            f"landmarks need (m,) triangles, (m, 3) barycentrics and (m, 3) targets with "
            f"m ≥ 1, got {lt.shape}, {lb.shape}, {ly.shape}"
        )
    lw = np.ones(m) if landmarks.weight is None else np.asarray(landmarks.weight, dtype=float)
    if lw.shape != (m,) or not np.all(np.isfinite(lw)) or np.any(lw < 0):
        raise ValueError(f"landmark weights must be ({m},) non-negative and finite")
    return lt, lb, ly, lw


def _check_options(o: NonrigidICPOptions) -> None:
    if o.iterations < 1 or o.landmark_weight <= 0 or o.max_distance <= 0 or len(o.stiffness) == 0:
        raise ValueError("iterations, landmark_weight, max_distance and stiffness must be positive")
    if any(a <= 0 for a in o.stiffness):
        raise ValueError(f"stiffness values must be positive, got {list(o.stiffness)}")
    sched = o.landmark_schedule
    if sched is not None and (
        len(sched) != len(o.stiffness) or any(not np.isfinite(b) or b < 0 for b in sched)
    ):
        raise ValueError(
            f"landmark_schedule needs one value ≥ 0 per stiffness stage ({len(o.stiffness)}), "
            f"got {list(sched)}"
        )
    if not (np.isfinite(o.symmetric) and o.symmetric >= 0):
        raise ValueError(f"symmetric must be a finite weight ≥ 0, got {o.symmetric}")
    if not (0.0 <= o.vertex_pull <= 1.0) or o.vertex_pull_from < 0:
        raise ValueError(
            f"vertex_pull must be in [0, 1] and vertex_pull_from ≥ 0, got {o.vertex_pull} "
            f"and {o.vertex_pull_from}"
        )
    if o.landmark_retarget is not None and not 1 <= o.landmark_retarget <= len(o.stiffness):
        raise ValueError(
            f"landmark_retarget must be in 1 … {len(o.stiffness)}, got {o.landmark_retarget}"
        )


def _stage_betas(o: NonrigidICPOptions) -> list[float]:
    """β of every stage of the schedule."""
    if o.landmark_schedule is None:
        return [float(o.landmark_weight)] * len(o.stiffness)
    return [float(b) for b in o.landmark_schedule]


@dataclass(frozen=True)
class _ICPSystem:
    """The fixed parts of the ICP's normal equations (eq. of the module docstring)."""

    K: sp.csc_array  # bi-Laplacian energy ∫|Δd|² / A
    BtB: sp.csc_array  # 1/m BᵀΩB, B the landmark barycentric map (times β per stage)
    rhs_lm: FloatArray  # 1/m BᵀΩ(y − BX) (times β per stage)
    a_bar: FloatArray  # vertex areas / total area
    B: sp.csc_array  # the landmark barycentric map (m, n)
    BtW: sp.csc_array  # BᵀΩ / m

    def retargeted(self, X: FloatArray, targets: FloatArray) -> _ICPSystem:
        """The same system with the landmark targets replaced by ``targets`` (m, 3)."""
        rhs = self.BtW @ (targets - self.B @ X)
        return _ICPSystem(self.K, self.BtB, rhs, self.a_bar, self.B, self.BtW)


def _icp_system(
    X: FloatArray, F: IntArray, lm: tuple[IntArray, FloatArray, FloatArray, FloatArray]
) -> _ICPSystem:
    lt, lb, ly, lw = lm
    n, m = X.shape[0], lt.size
    L = cotangent_laplacian(X, F)
    A = vertex_areas(X, F)
    if np.any(A <= 0):
        raise ValueError(f"{int((A <= 0).sum())} source vertices have no area (unreferenced?)")
    A_tot = float(A.sum())
    A_mass = np.maximum(A, ICP_MASS_FLOOR * A_tot / n)  # see ICP_MASS_FLOOR
    K = sp.csc_array(L @ sp.diags_array(1.0 / A_mass) @ L) / A_tot  # ∫|Δd|² / A
    B = sp.csc_array((lb.ravel(), (np.repeat(np.arange(m), 3), F[lt].ravel())), shape=(m, n))
    BtW = sp.csc_array(B.T @ sp.diags_array(lw)) / m
    BtB = sp.csc_array(BtW @ B)
    rhs_lm = BtW @ (ly - B @ X)
    return _ICPSystem(K, BtB, rhs_lm, A / A_tot, B, BtW)


def _target_pull(
    X: FloatArray,
    F: IntArray,
    Xt: FloatArray,
    Ft: IntArray,
    options: NonrigidICPOptions,
) -> Callable[[FloatArray], tuple[sp.csc_array, FloatArray]]:
    """The symmetric term's normal equations at a deformed source Y: every target
    vertex t_j matched to its closest point on Y (triangle s_j, barycentrics b_j),
    ``(PᵀWP, PᵀW(t − P X))`` with P the (n_t, n) barycentric map and W the target's
    normalised vertex areas times the match test."""
    At = vertex_areas(Xt, Ft)
    a_t = At / float(At.sum())
    vn_t = vertex_normals(Xt, Ft)
    n = X.shape[0]

    def pull(Y: FloatArray) -> tuple[sp.csc_array, FloatArray]:
        sd = SurfaceDistance(Y, F)
        c, dist, tri = sd.closest_triangles(Xt, k=8)
        bc = projected_barycentrics(c, Y[F[tri]])
        cos = np.einsum("ij,ij->i", vn_t, _face_normals(Y, F)[tri])
        ok = (dist <= options.max_distance) & (cos >= options.min_normal_cosine)
        w = a_t * ok
        m = Xt.shape[0]
        P = sp.csc_array((bc.ravel(), (np.repeat(np.arange(m), 3), F[tri].ravel())), shape=(m, n))
        PtW = sp.csc_array(P.T @ sp.diags_array(w))
        return sp.csc_array(PtW @ P), PtW @ (Xt - P @ X)

    return pull


def _factor_and_solve(
    Mx: sp.csc_array, rhs: FloatArray, refactor: SymmetricRefactorization
) -> tuple[Factorization, FloatArray, float]:
    """Factorise (numerically only, on ``refactor``'s analysis of the stages' one pattern)
    and solve; on a failed solve, again with the diagonal shifts of
    :data:`ICP_DIAGONAL_SHIFTS` (each diagonal entry raised by that fraction of itself). Returns the
    factorisation, the solution and the relative shift used (0: none)."""
    try:
        fac = refactor.factorize(Mx, sp.csc_array(sp.triu(Mx, format="csc")))
        return fac, fac.solve(rhs), 0.0
    except SingularSystemError as exc:
        error = exc
    diag = Mx.diagonal()
    for shift in ICP_DIAGONAL_SHIFTS:
        shifted = sp.csc_array(Mx + sp.diags_array(shift * diag))
        try:
            fac = factorize(shifted, symmetric=True)
            return fac, fac.solve(rhs), shift
        except SingularSystemError as exc:
            error = exc
    raise error


def _icp_iterations(
    X: FloatArray,
    d: FloatArray,
    w_user: FloatArray,
    system: _ICPSystem,
    match: Callable[[FloatArray, int], tuple[FloatArray, FloatArray, IntArray, BoolArray]],
    options: NonrigidICPOptions,
    project: Callable[[FloatArray], FloatArray],
    pull: Callable[[FloatArray], tuple[sp.csc_array, FloatArray]] | None = None,
) -> tuple[FloatArray, list[dict[str, float]]]:
    """The stiffness schedule: correspondences (``match`` of the deformed source and the
    stage), then the regularised solve for d (``project``: points (k, 3) → their closest
    target points, for the retarget)."""
    history: list[dict[str, float]] = []
    # every stage's matrix α K + diag(w) + β BᵀB has K's pattern (its diagonal included)
    # plus BᵀB's: the ordering and elimination tree are computed once, each stiffness
    # only refactorises numerically (the same factors as a fresh factorisation)
    refactor = SymmetricRefactorization()
    fac: Factorization | None = None
    fac_key = (float("nan"), float("nan"))
    stages = zip(options.stiffness, _stage_betas(options), strict=True)
    for stage, (alpha, beta) in enumerate(stages):
        if stage == options.landmark_retarget:
            system = system.retargeted(X, project(system.B @ (X + d)))
        for _ in range(options.iterations):
            c, dist, _, ok = match(X + d, stage)
            w = system.a_bar * w_user * ok
            Mx = sp.csc_array(alpha * system.K + sp.diags_array(w) + beta * system.BtB)
            rhs = w[:, None] * (c - X) + beta * system.rhs_lm
            if pull is not None:  # the symmetric term: target vertices pull the source
                PtP, rhs_pull = pull(X + d)
                Mx = sp.csc_array(Mx + options.symmetric * PtP)
                rhs = rhs + options.symmetric * rhs_pull
            d_new, n_cg = None, 0
            if fac is not None and (alpha, beta) == fac_key:
                # same stiffness, a few matches changed: the last factorisation
                # preconditions CG from the current displacement
                d_new, n_cg = preconditioned_cg(
                    Mx, rhs, fac, d, rtol=ICP_CG_RTOL, max_iterations=ICP_CG_MAX_ITERATIONS
                )
            shift = 0.0
            if d_new is None:
                fac, d_new, shift = _factor_and_solve(Mx, rhs, refactor)
                fac_key, n_cg = (float(alpha), beta), 0
            wsum = float(w.sum())
            history.append(
                {
                    "stiffness": float(alpha),
                    "rms_distance": float(np.sqrt(np.sum(w * dist**2) / wsum))
                    if wsum
                    else float("nan"),
                    "matched": float(ok.sum()),
                    "step": float(np.abs(d_new - d).max()),
                    "cg_iterations": float(n_cg),
                    "shift": shift,
                }
            )
            d = d_new
    return d, history


def nonrigid_icp(
    source_V: FloatArray,
    source_F: IntArray,
    target_V: FloatArray,
    target_F: IntArray,
    landmarks: ICPLandmarks,
    *,
    initial_displacement: FloatArray | None = None,
    weights: FloatArray | None = None,
    options: NonrigidICPOptions | None = None,
    target_distance: SurfaceDistance | None = None,
) -> NonrigidICPResult:
    """Deform a source mesh smoothly onto a target surface (see the module docstring).

    Parameters
    ----------
    source_V : (n, 3) float64
        Source vertices, aligned with the target (e.g. diameter-normalised).
    source_F : (k, 3) int64
        Source triangles (a manifold mesh; its cotangent Laplacian regularises).
    target_V : (n1, 3) float64
    target_F : (k1, 3) int64
    landmarks : ICPLandmarks
        (m,) source triangles, (m, 3) barycentrics, (m, 3) target points.
    initial_displacement : (n, 3) float64, optional
        Starting d (default 0), e.g. from a landmark registration.
    weights : (n,) float64, optional
        Non-negative data weights w_v (default 1), e.g. 0 near the border,
        where the target's border differs.
    options : NonrigidICPOptions, optional
        Stiffness schedule and matching thresholds (default ``NonrigidICPOptions()``).
    target_distance : SurfaceDistance, optional
        Prepared closest-point structure of the target, reused if given.

    Returns
    -------
    NonrigidICPResult

    Raises
    ------
    ValueError
        On inconsistent shapes or non-positive parameters.

    References
    ----------
    B. Amberg, S. Romdhani, T. Vetter, "Optimal Step Nonrigid ICP Algorithms
    for Surface Registration", CVPR 2007. doi:10.1109/CVPR.2007.383165
    """
    options = NonrigidICPOptions() if options is None else options
    X = np.asarray(source_V, dtype=np.float64)
    F = np.asarray(source_F, dtype=np.int64)
    Xt = np.asarray(target_V, dtype=np.float64)
    Ft = np.asarray(target_F, dtype=np.int64)
    n = X.shape[0]
    if X.ndim != 2 or X.shape[1] != 3 or Xt.ndim != 2 or Xt.shape[1] != 3:
        raise ValueError(f"source_V and target_V must be (n, 3), got {X.shape} and {Xt.shape}")
    lm = _checked_landmarks(landmarks)
    d = (
        np.zeros_like(X)
        if initial_displacement is None
        else np.array(initial_displacement, dtype=np.float64)
    )
    if d.shape != X.shape:
        raise ValueError(f"initial_displacement must be {X.shape}, got {d.shape}")
    w_user = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64)
    if w_user.shape != (n,) or np.any(w_user < 0):
        raise ValueError(f"weights must be ({n},) non-negative")
    _check_options(options)
    system = _icp_system(X, F, lm)
    sd = target_distance or SurfaceDistance(Xt, Ft)
    nt = _face_normals(Xt, Ft)

    vertices = (
        MutualNearestVertices(Xt, vertex_normals(Xt, Ft)) if options.vertex_pull > 0 else None
    )

    source_normals = VertexNormals(F, n)  # the source's connectivity, set up once

    def match(Y: FloatArray, stage: int) -> tuple[FloatArray, FloatArray, IntArray, BoolArray]:
        """Correspondences of the deformed source Y at ``stage`` (−1: the result's own
        closest points): closest points, blended with mutual nearest target vertices."""
        c, dist, tri = sd.closest_triangles(Y, k=8)
        vn = source_normals(Y)
        cos = np.einsum("ij,ij->i", vn, nt[tri])
        ok = (dist <= options.max_distance) & (cos >= options.min_normal_cosine)
        if vertices is not None and stage >= options.vertex_pull_from:
            vp = vertices.pairs(Y, vn, options.max_distance, options.vertex_pull_normal_cosine)
            g = options.vertex_pull * vp.paired[:, None]
            c = (1.0 - g) * c + g * Xt[vp.target]
        return c, dist, tri, ok

    def project(Y: FloatArray) -> FloatArray:
        return np.asarray(sd.closest_triangles(Y, k=8)[0])

    pull = None
    if options.symmetric > 0:
        pull = _target_pull(X, F, Xt, Ft, options)
    d, history = _icp_iterations(X, d, w_user, system, match, options, project, pull)
    Y = X + d
    c, dist, tri, ok = match(Y, -1)
    return NonrigidICPResult(Y, c, dist, tri, projected_barycentrics(c, Xt[Ft[tri]]), ok, history)
