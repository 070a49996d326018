"""The frames of the strain morph, solved one after the other (the paper's step 4).

Each requested time is reached in steps of at most ``max_time_step``; each step is
solved from a warm start (the previous frame or its linear extrapolation) by
:func:`conformorph.geometry.strain_newton.barrier_newton`, or by Newton (eq. 11) with the
continuation of eq. (12) for N = 2, 4, …; when that fails the time step is
halved ("insert more frames") up to ``max_substeps`` times. An iteration budget
bounds the whole call.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from ._typing import FloatArray, IntArray
from .green_lagrange_strain import StrainScheme
from .strain_newton import FrameResult, barrier_newton, continuation_newton
from .strain_system import StrainSystem
from .strain_targets import strain_target
from .tolerances import (
    STRAIN_LAST_FRAME_TOL_FACTOR,
    STRAIN_MAX_TIME_STEP,
    STRAIN_NEWTON_STEP_RTOL,
)

Predictor = Literal["previous", "linear"]
Solver = Literal["barrier", "newton"]


@dataclass(frozen=True)
class StrainMorphOptions:
    """Solver knobs of :func:`conformorph.geometry.strain_morph.strain_morph`.

    Attributes
    ----------
    tol : float
        δ of the stopping rule ``‖V_{l+1} − V_l‖_F < δ``, relative to the
        bounding-box diagonal of the source (``STRAIN_NEWTON_STEP_RTOL``).
    max_iterations : int
        Newton iterations allowed per attempt at one frame (30).
    max_continuation : int
        Largest N of the continuation method (eq. 12); N doubles from 2 (64).
    max_substeps : int
        How often a time step may be halved when continuation fails (8).
    max_time_step : float
        Largest time step the solver takes (``STRAIN_MAX_TIME_STEP``, 1/60):
        between two requested times further apart, evenly spaced intermediate
        frames are solved as warm starts and not returned (their iterations and
        substeps count towards the next requested frame). A coarse frame request
        must not decide the solver's path: with 5 frames the stick figures' path
        jumped to another branch of W's minimisers and ended 0.8 % of the
        target's size from it, with steps of at most 1/60 it reaches the target.
    predictor : {"linear", "previous"}
        Warm start: the previous frame (the paper) or its linear extrapolation
        from the two previous frames (default; about one Newton iteration fewer
        per frame, and the previous frame is used whenever the extrapolation
        would flip a triangle).
    solver : {"barrier", "newton"}
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
    max_total_iterations : int or None
        Newton iterations allowed for the whole call (default None: no limit).
        Checked before every attempt at a frame or an inserted sub-step: once
        spent, nothing more is solved; the frame in progress ends ``"budget"``
        and, like every later frame (also ``"budget"``), repeats the last state
        solved. Bounds the time of a hopeless morph: on S → U with the corner
        rule's anchors (1250 vertices) eq. (3) in the principal frame spent 840 s
        (2 shared cores) without reaching the target, while the morphs of
        ``benchmarks/bench_morph2d.py`` that converge (61 frames; horse → heart
        not run) spend 121 (annulus) to 1173 iterations (stick figures, eq. 2).
    max_step_halvings : int or None
        Halvings of the time step allowed per solver time step before the whole
        call stops as stalled (default None: only ``max_substeps`` bounds each
        recursion). The path of minimisers is then folding: each halving that
        fails costs up to ``max_iterations`` iterations, and a step halved eight
        times deep costs hundreds. Once exceeded the frame in progress ends
        ``"stalled"`` and, like every later frame (also ``"stalled"``), repeats
        the last state solved. Measured on the anchor-free pairs of
        ``benchmarks/bench_outline_matching.py`` (60 frames, 1/60 steps): every
        scheme that reached its target halved no step, except eq. (3) on C → S
        and S → U, which reached it after 10 and 14 halvings of its last step
        (534 and 746 iterations; eq. 3 in the principal frame needs about 10 per
        frame there); the schemes that never reach the target halve 4 to 45
        times per frame in their last frames and spend the whole iteration
        budget there (horse → heart: 3000 iterations each of eq. 3 and eq. 3 in
        the principal frame, 3.2 s each, before eq. 2 reached the target in 419).
        A count of halvings is a fragile rule, though: it stops schemes that
        would recover, and whether it trips depends on the frame count and on
        round-off; the pipeline uses ``stall_iterations`` instead.
    stall_iterations : int or None
        Newton iterations the call may spend without its time advancing by half
        of ``max_time_step`` (every attempt counted, failed ones included) before
        it stops as stalled (default None: no limit). A rule on progress in t,
        not on the number of halvings: a step halved many times that then
        advances resets it, a path that folds (every attempt fails, or the
        halved steps creep) spends it. The frame in progress and every later
        frame then end ``"stalled"`` and repeat the last state solved, as with
        ``max_step_halvings``.
    reuse_factor : bool
        Barrier solver: after a full step whose increment is under half the
        previous one, take a chord step with the last factorisation of K
        (modified Newton) instead of assembling and factorising K again (see
        :func:`conformorph.geometry.strain_newton.barrier_newton`). Default False:
        measured on 60 frames, eq. 2 on horse → heart (644 vertices) took 620
        iterations instead of 419 in the same 0.39–0.45 s and ended 7.8e-6 of
        the target's size from it instead of 5.1e-8; eq. 3 in the principal frame
        on horse → star with the committed anchors (2673 vertices) 870 instead of
        653 iterations, 1.9–2.2 s instead of 2.3–2.5 s (load average 2.7). Most
        frames take 3 Newton iterations, so one refactorisation saved per frame
        is offset by the chord steps' slower convergence.
    polish_last_frame : bool
        Solve the frame at t = 1, once converged, again from itself to
        ``STRAIN_LAST_FRAME_TOL_FACTOR`` of ``tol`` (kept when that converges).
        Default True: near slivers Newton converges slowly, and a step under
        ``tol`` can stop well short of the target (U → Z with no anchors: eq. 3 in
        the principal frame ended 7e-4 of the target's size from it, eq. 2 1.5e-3;
        polished, the target is reached).
    monotone_area : bool
        Keep the total area each frame's interpolated strain prescribes between
        the source's and the target's, by dilating that strain uniformly where
        it leaves that range (:func:`conformorph.geometry.strain_targets.strain_target`
        with the rest areas). Default True: eq. (3) swells triangles that are
        stretched one way and squashed the other mid-way, and the whole outline
        with them (L → T with no anchors: 1.49 of the source's area mid-way, the
        target about 1.1). False: eq. (2)/(3) exactly as the paper.
    """

    tol: float = STRAIN_NEWTON_STEP_RTOL
    max_iterations: int = 30
    max_continuation: int = 64
    max_substeps: int = 8
    max_time_step: float = STRAIN_MAX_TIME_STEP
    predictor: Predictor = "linear"
    solver: Solver = "barrier"
    max_total_iterations: int | None = None
    max_step_halvings: int | None = None
    stall_iterations: int | None = None
    reuse_factor: bool = False
    polish_last_frame: bool = True
    monotone_area: bool = True


def check_strain_morph_options(options: StrainMorphOptions) -> None:
    """Raise ValueError naming the first knob of ``options`` out of its range.

    Parameters
    ----------
    options : StrainMorphOptions

    Raises
    ------
    ValueError
    """
    o = options
    if o.max_iterations < 1 or o.max_continuation < 1 or o.max_substeps < 0 or not o.tol > 0:
        raise ValueError("max_iterations, max_continuation must be ≥ 1, max_substeps ≥ 0, tol > 0")
    if not 0.0 < o.max_time_step <= 1.0:
        raise ValueError(f"max_time_step must be in (0, 1], got {o.max_time_step}")
    if o.max_total_iterations is not None and o.max_total_iterations < 0:
        raise ValueError(f"max_total_iterations must be ≥ 0, got {o.max_total_iterations}")
    if o.max_step_halvings is not None and o.max_step_halvings < 0:
        raise ValueError(f"max_step_halvings must be ≥ 0, got {o.max_step_halvings}")
    if o.stall_iterations is not None and o.stall_iterations < 1:
        raise ValueError(f"stall_iterations must be ≥ 1, got {o.stall_iterations}")
    if o.solver not in ("barrier", "newton"):
        raise ValueError(f"solver must be 'barrier' or 'newton', got {o.solver!r}")
    if o.predictor not in ("linear", "previous"):
        raise ValueError(f"predictor must be 'linear' or 'previous', got {o.predictor!r}")


def solve_frame(
    system: StrainSystem,
    X_warm: FloatArray,
    eps_t: FloatArray,
    d_star: FloatArray,
    abs_tol: float,
    options: StrainMorphOptions,
) -> FrameResult:
    """One frame from a warm start: barrier Newton, or Newton (eq. 11) then continuation (eq. 12).

    With ``options.solver == "newton"``, plain Newton is tried first; while it
    fails the frame is redone from the warm start with the continuation of
    eq. (12) for N = 2, 4, 8, … ``options.max_continuation`` (``max_iterations
    + N`` iterations each). The iterations of every attempt are counted.

    Parameters
    ----------
    system : StrainSystem
    X_warm : (n, 2) float64
    eps_t : (m, 3) float64
        Target strain (eq. 2 or 3).
    d_star : (m,) float64
        Area ratios it prescribes (used by the barrier).
    abs_tol : float
        Absolute step tolerance δ.
    options : StrainMorphOptions

    Returns
    -------
    FrameResult
    """
    if options.solver == "barrier":
        return barrier_newton(
            system,
            X_warm,
            eps_t,
            d_star,
            abs_tol,
            options.max_iterations,
            reuse_factor=options.reuse_factor,
        )
    res = continuation_newton(system, X_warm, eps_t, 1, abs_tol, options.max_iterations)
    spent = res.iterations
    N = 2
    while res.reason != "converged" and N <= options.max_continuation:
        res = continuation_newton(system, X_warm, eps_t, N, abs_tol, options.max_iterations + N)
        spent += res.iterations
        N *= 2
    res.iterations = spent
    return res


@dataclass(frozen=True)
class SolvedFrames:
    """The frames of :func:`solve_frames` in the gauge frame, with their solver records.

    Attributes
    ----------
    X : (T, n, 2) float64
    iterations : (T,) int64
    continuation : (T,) int64
    substeps : (T,) int64
    steps : (T,) float64
        Last absolute Newton step (inf when none).
    stop_reasons : tuple of str
    area_gains : (T,) float64 or None
        The ``area_gain`` each frame's strain was computed with
        (:func:`conformorph.geometry.strain_targets.strain_target`; None: no
        total-area bound).
    """

    X: FloatArray
    iterations: IntArray
    continuation: IntArray
    substeps: IntArray
    steps: FloatArray
    stop_reasons: tuple[str, ...]
    area_gains: FloatArray | None = None


#: Stop reasons after which nothing more is solved in a call.
_FINAL = ("converged", "budget", "stalled")


class _FrameMarch:
    """The time-stepping of :func:`solve_frames`, with its iteration budget."""

    def __init__(
        self,
        system: StrainSystem,
        eps_n: FloatArray,
        scheme: StrainScheme,
        abs_tol: float,
        options: StrainMorphOptions,
    ) -> None:
        self.system, self.eps_n, self.scheme = system, eps_n, scheme
        self.abs_tol, self.options = abs_tol, options
        self.spent_total = 0  # Newton iterations of every attempt so far
        self.halvings = 0  # halvings of the current solver time step
        self.stalled = False
        # progress mark of the stall rule: the time last reached by half a step
        # beyond the previous mark, and the iterations spent when it was
        self.mark_t, self.mark_spent = 0.0, 0
        self.rest_areas = system.area if options.monotone_area else None
        # solved over prescribed total area of the last frame solved (the bound's feedback)
        self.gain = self.used_gain = 1.0

    def solve_at(self, t: float, Xw: FloatArray) -> FrameResult:
        cap = self.options.max_total_iterations
        if self.stalled:
            return FrameResult(Xw.copy(), 0, 1, np.inf, "stalled")
        if cap is not None and self.spent_total >= cap:
            return FrameResult(Xw.copy(), 0, 1, np.inf, "budget")
        idle = self.options.stall_iterations
        if idle is not None and self.spent_total - self.mark_spent >= idle:
            self.stalled = True  # no progress in t for that many iterations
            return FrameResult(Xw.copy(), 0, 1, np.inf, "stalled")
        eps_t, d_star = strain_target(self.eps_n, t, self.scheme, self.rest_areas, self.gain)
        res = solve_frame(self.system, Xw, eps_t, d_star, self.abs_tol, self.options)
        self.spent_total += res.iterations
        if res.reason == "converged":
            if self.rest_areas is not None:
                self.used_gain = self.gain
                a = self.rest_areas
                self.gain = float(a @ self.system.det(res.X)) / float(a @ d_star)
            if t >= self.mark_t + 0.5 * self.options.max_time_step:
                self.mark_t, self.mark_spent = t, self.spent_total
        return res

    def advance(
        self, t_prev: float, t: float, Xw: FloatArray, depth: int
    ) -> tuple[FrameResult, int]:
        """Solve at t; on failure halve the step [t_prev, t] (recursively)."""
        res = self.solve_at(t, Xw)
        if res.reason in _FINAL or depth >= self.options.max_substeps:
            return res, 0
        limit = self.options.max_step_halvings
        if limit is not None and self.halvings >= limit:
            self.stalled = True  # the path is folding: stop here, not at the budget
            return FrameResult(Xw.copy(), res.iterations, 1, np.inf, "stalled"), 0
        self.halvings += 1
        mid = 0.5 * (t_prev + t)
        first, sub1 = self.advance(t_prev, mid, Xw, depth + 1)
        if first.reason != "converged":
            first.iterations += res.iterations
            return first, sub1 + 1
        second, sub2 = self.advance(mid, t, first.X, depth + 1)
        second.iterations += res.iterations + first.iterations
        return second, sub1 + sub2 + 1

    def polish(self, res: FrameResult) -> FrameResult:
        """The converged frame at t = 1 solved again from itself to
        ``STRAIN_LAST_FRAME_TOL_FACTOR`` of the step tolerance (kept if that converges)."""
        eps_t, d_star = strain_target(self.eps_n, 1.0, self.scheme, self.rest_areas)
        tol = self.abs_tol * STRAIN_LAST_FRAME_TOL_FACTOR
        tight = solve_frame(self.system, res.X, eps_t, d_star, tol, self.options)
        self.spent_total += tight.iterations
        if tight.reason != "converged":
            return res
        tight.iterations += res.iterations
        tight.continuation = res.continuation  # the level that reached the frame
        return tight

    def predict(
        self, prev_X: FloatArray, prev_t: float, older: tuple[FloatArray, float] | None, t: float
    ) -> FloatArray:
        """Warm start at t: the previous frame or its linear extrapolation."""
        if self.options.predictor == "linear" and older is not None and prev_t > older[1]:
            w = (t - prev_t) / (prev_t - older[1])
            guess = prev_X + w * (prev_X - older[0])
            if np.min(self.system.det(guess)) > 0.0:
                return guess
        return prev_X


def solve_frames(
    system: StrainSystem,
    rest: FloatArray,
    eps_n: FloatArray,
    times: FloatArray,
    scheme: StrainScheme,
    abs_tol: float,
    options: StrainMorphOptions,
) -> SolvedFrames:
    """Every requested frame, each warm-started from the last one solved (step 4).

    Parameters
    ----------
    system : StrainSystem
    rest : (n, 2) float64
        The source in the gauge frame (the frame at t = 0).
    eps_n : (m, 3) float64
        Final strain field (eq. 1).
    times : (T,) float64
        Non-decreasing, in [0, 1].
    scheme : {"modified", "linear", "principal"}
        Strain interpolation (eq. 3, eq. 2, eq. 3 in principal frames).
    abs_tol : float
        Absolute step tolerance δ.
    options : StrainMorphOptions

    Returns
    -------
    SolvedFrames
    """
    march = _FrameMarch(system, eps_n, scheme, abs_tol, options)
    T_count = times.shape[0]
    X_all = np.zeros((T_count, rest.shape[0], 2))
    iterations = np.zeros(T_count, dtype=np.int64)
    continuation = np.ones(T_count, dtype=np.int64)
    substeps = np.zeros(T_count, dtype=np.int64)
    steps = np.zeros(T_count)
    gains = np.ones(T_count)
    reasons: list[str] = []
    prev_X, prev_t = rest, 0.0
    older: tuple[FloatArray, float] | None = None
    for i, t_i in enumerate(times):
        t = float(t_i)
        if t == 0.0:
            res = FrameResult(rest.copy(), 0, 1, 0.0, "converged")
            sub = 0
        else:
            # intermediate warm-start frames, so that no step exceeds max_time_step
            k = max(1, int(np.ceil((t - prev_t) / options.max_time_step - 1e-9)))
            spent = sub = 0
            for j in range(1, k + 1):
                tj = t if j == k else prev_t + (t - prev_t) * j / k
                march.halvings = 0
                res, sj = march.advance(prev_t, tj, march.predict(prev_X, prev_t, older, tj), 0)
                spent += res.iterations
                sub += sj
                if res.reason in ("budget", "stalled"):  # the last solved state, not a warm start
                    res = FrameResult(prev_X.copy(), 0, 1, np.inf, res.reason)
                    break
                if j < k:
                    sub += 1
                    older = (prev_X, prev_t)
                    prev_X, prev_t = res.X, tj
            res.iterations = spent
            if t == 1.0 and res.reason == "converged" and options.polish_last_frame:
                res = march.polish(res)
        X_all[i] = res.X
        iterations[i] = res.iterations
        continuation[i] = res.continuation
        substeps[i] = sub
        steps[i] = res.step
        gains[i] = march.used_gain if 0.0 < t < 1.0 else 1.0
        reasons.append(res.reason)
        if t > prev_t:
            older = (prev_X, prev_t)
        prev_X, prev_t = res.X, t
    area_gains = gains if march.rest_areas is not None else None
    return SolvedFrames(
        X_all, iterations, continuation, substeps, steps, tuple(reasons), area_gains
    )
