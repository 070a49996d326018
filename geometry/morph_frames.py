"""Morph frames from key frames on a consistent mesh: the cubic spline homotopy of section 4.

For every frame time t the disk positions :math:`\\mathscr D(q, t)`, the
curvature and the conformal factor :math:`\\lambda(t)` are spline-interpolated
from the key frames, the surface is reconstructed by Algorithm 1
(:func:`conformorph.geometry.reconstruct_surface`) with its boundary interpolated the same
way, and the similarity (rotation, translation, scale) that was taken out by
the diameter normalisation and rigid alignment is interpolated apart and put
back (:mod:`conformorph.geometry.rotation_interpolation`).

Three homotopies of the curvature are offered:

``key_lengths`` given ("metric")
    spline of the mean-curvature vector :math:`H\\mathbf n` in the common
    aligned frame, reconstructed by one linear solve per frame with the
    cotangent Laplacian of the interpolated metric (edge lengths);
vector curvature, no ``key_lengths`` ("vector")
    the same vector with the flat disk's Laplacian at :math:`\\mathscr D(q,t)`
    and λ-weighted areas (:func:`conformorph.geometry.reconstruct_surface`);
scalar curvature ("scalar")
    the paper's spline of scalar H, reconstructed by Algorithm 1's
    normal-update iteration;
``key_lengths`` and ``screen_weight > 0`` ("screened")
    the metric homotopy screened towards the cubic spline of the key
    positions (see :func:`morph_frames`, Notes); the pipeline's default.

The default was chosen by measurement on the ICT sequence of
``benchmarks/bench_face_tables.py`` (curved path): relative L2 distance to
the true in-between surfaces with the oracle correspondence 0.4e-3–0.9e-3
(screened), 1.2e-3–3.9e-3 (metric), 2.1e-3–5.9e-3 (vector), 1.0e-2–1.8e-2
(scalar); with DMT keys of different connectivity 0.7e-3–1.2e-3 (screened),
3.4e-3–4.7e-3 (metric).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .intrinsic_laplacian import IntrinsicLaplacianPattern
from .mesh_edges import mesh_edges
from .reconstruct_surface import reconstruct_surface, reconstruction_operator
from .rigid_alignment import SimilarityTransform
from .rotation_interpolation import interpolate_similarity
from .sparse_factor import Factorization, factorize, preconditioned_cg
from .spline_homotopy import BoundaryCondition, SplineHomotopy
from .threads import map_in_threads, row_blocks

CurvatureHomotopy = Literal["vector", "scalar"]

#: relative residual |L x − b| / |b| (per column) a preconditioned CG frame
#: solve must reach. Measured on two 68k-vertex faces, 30 frames
#: (``benchmarks/bench_face_speed.py``): frames differ from the 1e-8 solves by
#: at most 1e-6 diameters (the homotopy's own error is ~1e-3) and take 9 s
#: instead of 19 s.
PCG_RTOL = 1e-6
#: Screening weight (1/length², aligned frame of diameter 1) of the screened
#: metric homotopy: a screening length 1/√300 ≈ 0.06 diameters. Measured on the
#: ICT sequence of ``benchmarks/bench_face_tables.py`` (curved path), relative
#: L2 distance to the true in-between surfaces at t = 0.3, 0.5, 1.3, 1.5 with
#: DMT keys of different connectivity: w = 0 (plain metric) 3.4e-3, 4.2e-3,
#: 3.9e-3, 4.7e-3; w = 30: 1.5e-3, 1.8e-3, 1.6e-3, 2.0e-3; w = 300: 1.1e-3,
#: 1.2e-3, 0.7e-3, 0.9e-3; w = 3000: 0.95e-3, 0.95e-3, 0.65e-3, 0.88e-3.
SCREEN_WEIGHT = 300.0
#: CG iterations after which a frame refactorises instead (a fresh
#: factorisation then preconditions the following frames)
PCG_MAX_ITERATIONS = 8
#: Fewest frames of the metric homotopy per thread: the frames are split into
#: consecutive runs solved side by side (conformorph.geometry.threads), each run starting
#: with a factorisation of its own.
MIN_FRAMES_PER_THREAD = 8


def _extrapolate(history_t: list[float], history_x: list[FloatArray], t: float) -> FloatArray:
    """Next frame's starting guess: Lagrange extrapolation of up to three previous solutions.

    Parameters
    ----------
    history_t : list of float
        Times of the previous solutions (distinct).
    history_x : list of (p, c) float64
        The solutions.
    t : float
        This frame's time.

    Returns
    -------
    (p, c) float64
        The polynomial through the (at most three) last points, at ``t``; for
        equally spaced frames 1, 2, 3 points give x₋₁, 2x₋₁ − x₋₂ and
        3x₋₁ − 3x₋₂ + x₋₃.
    """
    ts = history_t[-3:]
    xs = history_x[-3:]
    out = np.zeros_like(xs[-1])
    for j, (tj, xj) in enumerate(zip(ts, xs, strict=True)):
        w = 1.0
        for m_, tm in enumerate(ts):
            if m_ != j:
                w *= (t - tm) / (tj - tm)
        out += w * xj
    return out


@dataclass(frozen=True)
class MorphFrames:
    """Frames of a morph on a consistent mesh.

    Attributes
    ----------
    times : (T,) float64
        Frame times.
    V : (T, n, 3) float64
        Frames in the common normalised, aligned position.
    uv : (T, n, 2) float64
        Disk positions :math:`\\mathscr D(q, t)`.
    transforms : list of SimilarityTransform
        Per frame, the interpolated similarity that puts the frame in place:
        ``transforms[k].apply(V[k])`` is frame k in input coordinates.
    seconds : float
        Wall time.
    iterations : list of int
        Reconstruction iterations per frame (1 for the vector homotopy).
    method : str
        ``"vector"``, ``"scalar"`` or ``"vector-metric"``.
    clamped_triangles : int
        Triangle-inequality clamps of the metric Laplacian, summed over frames.
    factorizations : int
        Sparse factorisations made (metric Laplacian; the others used PCG).
    """

    times: FloatArray
    V: FloatArray
    uv: FloatArray
    transforms: list[SimilarityTransform]
    seconds: float
    iterations: list[int] = field(default_factory=list)
    method: str = "vector"
    clamped_triangles: int = 0
    factorizations: int = 0

    def placed(self, k: int) -> FloatArray:
        """Frame k in input coordinates, (n, 3) float64."""
        return self.transforms[k].apply(self.V[k])


def _check_keys(times: FloatArray, arrays: dict[str, FloatArray], n: int) -> int:
    N1 = times.size
    if times.ndim != 1 or N1 < 2 or np.any(np.diff(times) <= 0):
        raise ValueError(f"key times must be ≥ 2 strictly increasing values, got {times.tolist()}")
    for name, a in arrays.items():
        if a.shape[:2] != (N1, n):
            raise ValueError(f"{name} must have shape ({N1}, {n}, ...), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} has non-finite values")
    return N1


@dataclass(frozen=True)
class HomotopyKeys:
    """The key frames a morph homotopy interpolates (:func:`morph_frames`).

    Attributes
    ----------
    times : (N + 1,) float64
        Key times :math:`t_0 < \\dots < t_N`.
    key_uv : (N + 1, n, 2) float64
        :math:`[\\bar f]_i(q)`: consistent nodes on every key disk.
    key_lam : (N + 1, n) float64
        Conformal factors :math:`\\lambda_i \\circ [\\bar f]_i` (positive).
    key_curvature : (N + 1, n) or (N + 1, n, 3) float64
        Scalar H (the paper's homotopy, Algorithm 1 iteration) or the
        mean-curvature vector Hn in the common aligned frame (one solve).
    key_boundary : (N + 1, k, 3) float64
        Key positions of the boundary vertices ``b`` (aligned frame).
    transforms : sequence of N + 1 SimilarityTransform, optional
        Per key, the similarity from the aligned frame back to the input's
        coordinates; interpolated apart (rotation on SO(3)). Default identity.
    key_lengths : (N + 1, e) float64, optional
        Key edge lengths (edges of :func:`conformorph.geometry.mesh_edges.mesh_edges`):
        the "metric" homotopy, one solve per frame with the cotangent
        Laplacian of the log-spline-interpolated lengths.
    key_positions : (N + 1, n, 3) float64, optional
        Key positions on the consistent mesh (aligned frame); needed when
        ``FrameSolveOptions.screen_weight > 0``.
    """

    times: FloatArray
    key_uv: FloatArray
    key_lam: FloatArray
    key_curvature: FloatArray
    key_boundary: FloatArray
    transforms: Sequence[SimilarityTransform] | None = None
    key_lengths: FloatArray | None = None
    key_positions: FloatArray | None = None


@dataclass(frozen=True)
class FrameSolveOptions:
    """Spline end conditions and solver knobs of :func:`morph_frames`.

    Attributes
    ----------
    bc_type : {"natural", "not-a-knot", "clamped"}
        Spline end conditions. Default "natural".
    reuse_operator : bool
        Factorise the disk Laplacian once at the key-0 disk positions and
        reuse it for every frame (faster; exact only when the positions
        :math:`\\mathscr D(q, t)` do not move, e.g. with the oracle
        correspondence on a shared disk). Default False: each frame factorises
        the Laplacian of its own :math:`\\mathscr D(\\cdot, t)`.
    pcg_frames : bool
        Metric homotopy: solve a frame by CG preconditioned with an earlier
        frame's factorisation (all three columns in lock step, started from
        the polynomial extrapolation of the last solutions), factorising
        afresh only when CG needs more than :data:`PCG_MAX_ITERATIONS`. A
        frame at a key time is always factorised: it then equals, to the bit,
        that key frame solved on its own (``frame_times`` = the key times), and
        reproduces the key to rounding. Default True.
    pcg_rtol : float
        Relative residual of those CG solves. Default :data:`PCG_RTOL`.
    screen_weight : float
        Metric homotopy only: the screened form (see :func:`morph_frames`,
        Notes), weight ``w`` in units of 1/length² of the aligned frame; 0
        (default) is the plain metric homotopy.
    """

    bc_type: BoundaryCondition = "natural"
    reuse_operator: bool = False
    pcg_frames: bool = True
    pcg_rtol: float = PCG_RTOL
    screen_weight: float = 0.0


@dataclass(frozen=True)
class _MetricProblem:
    """What every frame solve of the metric homotopy reads."""

    pattern: IntrinsicLaplacianPattern
    b: IntArray
    n: int
    te: FloatArray
    D: SplineHomotopy
    curv: SplineHomotopy
    bnd: SplineHomotopy
    positions: SplineHomotopy | None
    options: FrameSolveOptions
    key_times: frozenset[float] = frozenset()


def _metric_run(
    ks: IntArray, log_lengths: SplineHomotopy, P: _MetricProblem, V: FloatArray, uv: FloatArray
) -> tuple[list[int], int, int]:
    """Frames ``ks`` (consecutive) of the metric homotopy, into V and uv; returns
    (iterations per frame, factorisations, clamped cotangents). A frame at a key time
    is solved with a factorisation of its own, never by CG: it reproduces its key to
    rounding (as a solve of that frame alone does), not to the CG tolerance."""
    b, interior, w = P.b, P.pattern.interior, P.options.screen_weight
    run_its: list[int] = []
    run_fac, run_clamped = 0, 0
    fac_prev: Factorization | None = None
    history: list[FloatArray] = []
    history_t: list[float] = []
    for k in ks:
        t = float(P.te[k])
        uv[k] = P.D(t)
        L_II, L_IB, A, bad = P.pattern.blocks(np.exp(log_lengths(t)))
        run_clamped += bad
        rhs = 2.0 * A[:, None] * P.curv(t)
        X = np.zeros((P.n, 3))
        X[b] = P.bnd(t)
        r = rhs[interior] - L_IB @ X[b]
        if P.positions is not None:
            # screened: (L + w M) x = 2 M Hn + w M S_pos(t) on the interior
            A_I = A[interior]
            L_II = (L_II + sp.diags_array(w * A_I)).tocsc()
            r = r + w * A_I[:, None] * P.positions(t)[interior]
        x_int, n_it = None, 0
        at_key = t in P.key_times
        if fac_prev is not None and P.options.pcg_frames and history and not at_key:
            # the previous factorisation preconditions CG on this frame's Laplacian
            # (consecutive frames differ little), started from the extrapolated path
            x_int, n_it = preconditioned_cg(
                L_II,
                r,
                fac_prev,
                _extrapolate(history_t, history, t),
                rtol=P.options.pcg_rtol,
                max_iterations=PCG_MAX_ITERATIONS,
            )
        if x_int is None:
            fac_prev = factorize(L_II, symmetric=True)
            x_int = fac_prev.solve(r)
            run_fac += 1
            n_it = 1
        history = (history + [x_int])[-3:]
        history_t = (history_t + [t])[-3:]
        X[interior] = x_int
        V[k] = X
        run_its.append(n_it)
    return run_its, run_fac, run_clamped


def _checked_arrays(
    keys: HomotopyKeys, b: IntArray, te: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, list[SimilarityTransform]]:
    """The key arrays as float64, checked; the key transforms (identity by default)."""
    times = np.asarray(keys.times, dtype=np.float64)
    key_uv = np.asarray(keys.key_uv, dtype=np.float64)
    key_lam = np.asarray(keys.key_lam, dtype=np.float64)
    key_curvature = np.asarray(keys.key_curvature, dtype=np.float64)
    key_boundary = np.asarray(keys.key_boundary, dtype=np.float64)
    n = key_uv.shape[1] if key_uv.ndim == 3 else -1
    N1 = _check_keys(
        times, {"key_uv": key_uv, "key_lam": key_lam, "key_curvature": key_curvature}, n
    )
    if key_boundary.shape != (N1, b.size, 3):
        raise ValueError(
            f"key_boundary must have shape ({N1}, {b.size}, 3), got {key_boundary.shape}"
        )
    if np.any(key_lam <= 0):
        raise ValueError("key conformal factors must be positive")
    if not np.all(np.isfinite(te)):
        raise ValueError("frame times must be finite")
    transforms = keys.transforms
    T_keys = list(transforms) if transforms is not None else [SimilarityTransform.identity()] * N1
    if len(T_keys) != N1:
        raise ValueError(f"got {len(T_keys)} transforms for {N1} key times")
    return times, key_uv, key_lam, key_curvature, key_boundary, T_keys


def _metric_splines(
    keys: HomotopyKeys, F: IntArray, key_curvature: FloatArray, options: FrameSolveOptions
) -> tuple[SplineHomotopy | None, SplineHomotopy | None]:
    """The log edge-length spline (metric homotopy) and the key-position spline (screened)."""
    times = np.asarray(keys.times, dtype=np.float64)
    N1, n = times.size, np.shape(keys.key_uv)[1]
    bc_type = options.bc_type
    metric = None
    if keys.key_lengths is not None:
        kl = np.asarray(keys.key_lengths, dtype=np.float64)
        E = mesh_edges(F)
        if kl.shape != (N1, E.edges.shape[0]):
            raise ValueError(
                f"key_lengths must have shape ({N1}, {E.edges.shape[0]}), got {kl.shape}"
            )
        if key_curvature.ndim != 3:
            raise ValueError("the metric Laplacian needs the vector curvature homotopy")
        if not np.all(np.isfinite(kl)) or np.any(kl <= 0):
            raise ValueError("key edge lengths must be positive and finite")
        metric = SplineHomotopy(times, np.log(kl), bc_type=bc_type)
    screen_weight = options.screen_weight
    if not np.isfinite(screen_weight) or screen_weight < 0:
        raise ValueError(f"screen_weight must be ≥ 0, got {screen_weight}")
    positions = None
    if screen_weight > 0:
        if metric is None:
            raise ValueError("screen_weight needs the metric homotopy (key_lengths)")
        if keys.key_positions is None:
            raise ValueError("screen_weight > 0 needs key_positions")
        kp = np.asarray(keys.key_positions, dtype=np.float64)
        _check_keys(times, {"key_positions": kp}, n)
        if kp.shape[2:] != (3,):
            raise ValueError(f"key_positions must have shape ({N1}, {n}, 3), got {kp.shape}")
        positions = SplineHomotopy(times, kp, bc_type=bc_type)
    return metric, positions


def morph_frames(
    F: IntArray,
    b: IntArray,
    keys: HomotopyKeys,
    frame_times: FloatArray,
    options: FrameSolveOptions | None = None,
) -> MorphFrames:
    """Reconstruct morph frames from key frames on a consistent mesh (section 4).

    Parameters
    ----------
    F : (m, 3) int64
        Consistent mesh triangles.
    b : (k,) int64
        Its boundary vertices.
    keys : HomotopyKeys
        Key times and the key arrays the homotopy interpolates.
    frame_times : (T,) float64
        Times to reconstruct (outside [t0, tN]: extrapolation).
    options : FrameSolveOptions, optional
        Spline end conditions and solver knobs (default ``FrameSolveOptions()``).

    Returns
    -------
    MorphFrames

    Raises
    ------
    ValueError
        On inconsistent shapes, non-finite data, non-increasing times or a
        non-positive interpolated conformal factor.

    Notes
    -----
    The screened metric homotopy solves, per frame, ``(L + w M) x = 2 M Hn + w M
    S_pos(t)`` on the interior, ``S_pos`` the cubic spline of the key positions;
    every key is reproduced for any ``w`` and the frames tend to ``S_pos`` as ``w``
    grows.
    """
    t0 = time.perf_counter()
    options = FrameSolveOptions() if options is None else options
    bc_type = options.bc_type
    F = np.asarray(F, dtype=np.int64)
    b = np.asarray(b, dtype=np.int64)
    te = np.atleast_1d(np.asarray(frame_times, dtype=np.float64))
    times, key_uv, key_lam, key_curvature, key_boundary, T_keys = _checked_arrays(keys, b, te)
    n = key_uv.shape[1]
    D = SplineHomotopy(times, key_uv, bc_type=bc_type)
    # λ > 0 is interpolated in log space: a spline of λ itself can undershoot 0
    log_lam = SplineHomotopy(times, np.log(key_lam), bc_type=bc_type)
    curv = SplineHomotopy(times, key_curvature, bc_type=bc_type)
    bnd = SplineHomotopy(times, key_boundary, bc_type=bc_type)
    op0 = reconstruction_operator(key_uv[0], F, b) if options.reuse_operator else None
    metric, positions = _metric_splines(keys, F, key_curvature, options)

    V = np.zeros((te.size, n, 3))
    uv = np.zeros((te.size, n, 2))
    its: list[int] = []
    clamped = 0
    n_factorizations = 0
    if metric is not None:
        # consecutive runs of frames side by side on threads, each run chaining its own
        # factorisation and CG warm starts; at least MIN_FRAMES_PER_THREAD frames a run
        spline = metric
        problem = _MetricProblem(
            IntrinsicLaplacianPattern(F, b),
            b,
            n,
            te,
            D,
            curv,
            bnd,
            positions,
            options,
            frozenset(times.tolist()),
        )
        runs = row_blocks(np.arange(te.size), max(te.size, 1), MIN_FRAMES_PER_THREAD)
        for run_its, run_fac, run_clamped in map_in_threads(
            lambda ks: _metric_run(ks, spline, problem, V, uv), runs
        ):
            its += run_its
            n_factorizations += run_fac
            clamped += run_clamped
    for k, t in enumerate(te if metric is None else []):
        uv[k] = D(t)
        X, info = reconstruct_surface(
            uv[k] if op0 is None else key_uv[0],
            F,
            curv(t),
            np.exp(log_lam(t)),
            bnd(t),
            b=b,
            operator=op0,
        )
        V[k] = X
        its.append(int(info.iterations))
    placed = interpolate_similarity(times, T_keys, te)
    method = "vector" if key_curvature.ndim == 3 else "scalar"
    if metric is not None:
        method = "vector-metric"
    return MorphFrames(
        te, V, uv, placed, time.perf_counter() - t0, its, method, clamped, n_factorizations
    )


def linear_vertex_frames(
    times: FloatArray,
    key_V: FloatArray,
    frame_times: FloatArray,
) -> FloatArray:
    """Baseline: piecewise-linear interpolation of vertex positions between key frames.

    Parameters
    ----------
    times : (N + 1,) float64
        Key times.
    key_V : (N + 1, n, 3) float64
        Key positions on the consistent mesh (any common frame).
    frame_times : (T,) float64
        Outside [t0, tN] the first/last segment is continued linearly.

    Returns
    -------
    (T, n, 3) float64

    Notes
    -----
    On a path that is linear in vertex space between keys (e.g. a linear
    blend-shape path) this baseline is exact by construction.

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[[0.0, 0, 0]], [[2.0, 0, 0]]])
    >>> linear_vertex_frames(np.array([0.0, 1.0]), K, np.array([0.25, 1.5]))[:, 0, 0].tolist()
    [0.5, 3.0]
    """
    t = np.asarray(times, dtype=np.float64)
    K = np.asarray(key_V, dtype=np.float64)
    te = np.atleast_1d(np.asarray(frame_times, dtype=np.float64))
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("key times must be ≥ 2 strictly increasing values")
    if K.shape[0] != t.size:
        raise ValueError(f"key_V must have {t.size} keys, got {K.shape[0]}")
    seg = np.clip(np.searchsorted(t, te, side="right") - 1, 0, t.size - 2)
    s = (te - t[seg]) / (t[seg + 1] - t[seg])
    shape = (-1,) + (1,) * (K.ndim - 1)
    return np.asarray((1 - s).reshape(shape) * K[seg] + s.reshape(shape) * K[seg + 1])
