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
  reports it, and :mod:`conformorph.pipelines.morph2d.strain_interpolation` records any switch in
  ``metrics.json`` (``interp_fallback``).
* **Tangent matrix.** K of eq. (10) is the exact Hessian of W; it is
  factorised with :func:`conformorph.geometry.sparse_factor.factorize` (LDLᵀ), which
  raises on a singular solve.

The steps live in their own modules: rigid motion and gauge
(:mod:`conformorph.geometry.strain_rigid_motion`, steps 1 and 5), strain targets
(:mod:`conformorph.geometry.strain_targets`, eq. 1–3), W, φ and K
(:mod:`conformorph.geometry.strain_system`, eq. 4, 8–10), the per-frame solvers
(:mod:`conformorph.geometry.strain_newton`, eq. 11–12), the time stepping
(:mod:`conformorph.geometry.strain_frames`) and the diagnostics
(:mod:`conformorph.geometry.strain_diagnostics`).
"""

from __future__ import annotations

import time

import numpy as np

from ._typing import FloatArray, IntArray
from .green_lagrange_strain import (
    StrainScheme,
    deformation_gradient,
    shape_function_gradients,
    strain_from_gradient,
)
from .mesh_errors import NotTrianglesError
from .strain_diagnostics import StrainMorphInfo, strain_morph_info
from .strain_frames import StrainMorphOptions, check_strain_morph_options, solve_frames
from .strain_rigid_motion import gauge_vertices, restore_rigid_motion, rigid_motion, to_gauge
from .strain_system import StrainSystem
from .strain_targets import prescribed_area_ratio

__all__ = ["StrainMorphInfo", "StrainMorphOptions", "prescribed_area_ratio", "strain_morph"]


def strain_morph(
    source_V: FloatArray,
    target_V: FloatArray,
    F: IntArray,
    times: FloatArray,
    *,
    scheme: StrainScheme = "modified",
    reference_points: FloatArray | None = None,
    options: StrainMorphOptions | None = None,
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
        :func:`conformorph.geometry.green_lagrange_strain.interpolate_strain`).
    reference_points : (2, 2) float64, optional
        A⁰ (translation reference) and B⁰ (rotation reference), two distinct
        points inside the source shape; their target positions Aⁿ, Bⁿ are
        their images under the piecewise-linear map source → target. Default:
        the vertex nearest the centroid and the vertex farthest from it.
    options : StrainMorphOptions, optional
        Solver knobs (tolerance, iteration caps, continuation, sub-steps, largest
        time step, predictor, solver, iteration budget), each documented on
        :class:`conformorph.geometry.strain_frames.StrainMorphOptions`; default
        ``StrainMorphOptions()``.

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
    opts = StrainMorphOptions() if options is None else options
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
    check_strain_morph_options(opts)

    # validates F and the source triangles (ZeroAreaFaceError on a bad one)
    dN, area = shape_function_gradients(source_V, F)
    F = F.astype(np.int64)
    tgt_det = np.linalg.det(deformation_gradient(dN, target_V, F))
    if np.any(tgt_det <= 0):
        raise ValueError(
            f"{int(np.sum(tgt_det <= 0))} triangles are flipped or degenerate in target_V: "
            "the two meshes are not compatible"
        )
    # (1) the rigid motion through A and B, and the gauge: a nearest A, b farthest from a
    motion = rigid_motion(source_V, target_V, F, reference_points)
    a, b = gauge_vertices(source_V, motion.A0)
    rest = to_gauge(source_V, a, b)
    system = StrainSystem(rest, F, np.array([2 * a, 2 * a + 1, 2 * b + 1]))
    # (2) the final strain field ε^n (eq. 1)
    eps_n = strain_from_gradient(system.jacobians(to_gauge(target_V, a, b)))
    diag = float(np.linalg.norm(np.ptp(source_V, axis=0)))
    # (3)-(4) interpolated strains (eq. 2 / eq. 3) and the frames solved (eq. 9-12)
    solved = solve_frames(system, rest, eps_n, times, scheme, opts.tol * diag, opts)
    # (5) the interpolated rigid motion put back through A and B
    frames = restore_rigid_motion(solved.X, times, motion)
    info = strain_morph_info(
        system,
        solved,
        eps_n,
        times,
        scheme,
        (diag, float(area.sum())),
        (motion.rotation, motion.translation),
        time.perf_counter() - start,
        system.area if opts.monotone_area else None,
    )
    return frames, info
