"""Stage 2c (an extension of the paper, whose DMT uses the landmarks only): extra DMT
correspondences beyond the landmarks, by the presets of ``refine``: ``static`` / ``guided``
closest-point rounds (:func:`closest_point_refinement`), the non-rigid ICP of ``nicp``
(:func:`nicp_refinement`), ``none``; ``auto`` picks nicp or guided by the consistent
mesh's size (:func:`resolve_refine`)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.disk_registration import (
    KeyPair,
    dmt_through,
    meets_its_points,
)
from conformorph.pipelines.face_morph.options import RegistrationOptions

#: refine preset → (closest-point rounds, tolerance in diameters, guided)
REFINE_PRESETS = {
    "auto": (0, 3e-3, False),  # resolved by resolve_refine, once the consistent mesh is known
    "none": (0, 3e-3, False),
    "static": (1, 3e-3, False),
    "guided": (1, 5e-3, True),
    # the landmark DMT is the ICP's start and fallback: starting from the guided one
    # instead measured the same (bench_nicp_variants: 1.176, 1.212 against 1.178,
    # 1.208 at t = 1.3, 1.5) for 0.4 s more a pair
    "nicp": (0, 3e-3, False),
}


@dataclass(frozen=True)
class ResolvedRefine:
    """The refinement a registration runs, its preset resolved and overridden.

    Attributes
    ----------
    preset : str
        As asked (``RegistrationOptions.refine``).
    used : str
        The preset run (``auto`` resolved).
    rounds : int
        Closest-point rounds.
    tol : float
        Their distance tolerance (diameters).
    guided : bool
        Deformation-guided closest points.
    """

    preset: str
    used: str
    rounds: int
    tol: float
    guided: bool


def resolve_refine(options: RegistrationOptions, n_nodes: int) -> ResolvedRefine:
    """The refinement of ``options`` on a consistent mesh of ``n_nodes`` nodes.

    ``auto`` is ``nicp`` up to ``options.nicp_max_nodes`` nodes, ``guided`` above;
    the ``static_*`` options override the preset's rounds, tolerance and guidance.
    """
    if options.refine not in REFINE_PRESETS:
        raise ValueError(
            f"refine must be one of {', '.join(REFINE_PRESETS)}, got {options.refine!r}"
        )
    used = options.refine
    if used == "auto":
        used = "nicp" if n_nodes <= options.nicp_max_nodes else "guided"
    p_rounds, p_tol, p_guided = REFINE_PRESETS[used]
    return ResolvedRefine(
        preset=options.refine,
        used=used,
        rounds=p_rounds if options.static_refinement is None else options.static_refinement,
        tol=p_tol if options.static_tol is None else options.static_tol,
        guided=p_guided if options.static_guided is None else options.static_guided,
    )


def landmark_motion(
    source_points: NDArray[np.float64],
    target_points: NDArray[np.float64],
    at: NDArray[np.float64],
) -> tuple[NDArray[np.float64], int]:
    """The landmarks' 3D displacement interpolated in space (the guide of ``refine="guided"``).

    A polyharmonic spline with kernel r (:class:`scipy.interpolate.RBFInterpolator`,
    ``kernel="linear"``), exact at the landmarks. Its polynomial part is affine
    (degree 1) when the landmarks determine an affine map of space, i.e. when
    there are at least 4 of them and they are not coplanar; otherwise (m = 3,
    the fewest the pipeline accepts, or coplanar landmarks, where the affine
    part is not unique and the fit is singular) it is a constant (degree 0),
    the least polynomial part the r kernel needs. Both interpolate the
    landmark displacements exactly; degree 0 does not reproduce a global
    affine motion, which three landmarks cannot determine anyway.

    Parameters
    ----------
    source_points : (m, 3) float64
        Landmarks on the aligned source surface, m ≥ 1.
    target_points : (m, 3) float64
        The same landmarks on the aligned target surface.
    at : (p, 3) float64
        Where to evaluate the displacement.

    Returns
    -------
    motion : (p, 3) float64
        Predicted displacement at ``at``.
    degree : int
        The polynomial degree used (1 or 0).
    """
    from scipy.interpolate import RBFInterpolator

    src = np.asarray(source_points, dtype=np.float64)
    dst = np.asarray(target_points, dtype=np.float64)
    if src.ndim != 2 or src.shape[1] != 3 or src.shape != dst.shape or src.shape[0] < 1:
        raise ValueError(
            f"source_points and target_points must both be (m, 3) with m ≥ 1, got "
            f"{src.shape} and {dst.shape}"
        )
    degree = 0
    if src.shape[0] >= 4:
        c = src - src.mean(axis=0)
        sv = np.linalg.svd(c, compute_uv=False)
        if sv[2] > 1e-9 * max(sv[0], 1e-300):
            degree = 1
    rbf = RBFInterpolator(src, dst - src, kernel="linear", degree=degree)
    return np.asarray(rbf(np.asarray(at, dtype=np.float64))), degree


def closest_point_refinement(
    pair: KeyPair,
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    reg_d: Any,
    refine: ResolvedRefine,
    options: RegistrationOptions,
) -> tuple[Any, list[int], bool, int | None]:
    """The ``static`` / ``guided`` rounds: closest points as extra DMT landmarks.

    Farthest-point samples of the source (away from the rim and the landmarks) are
    matched to their closest points on the target surface
    (:func:`conformorph.geometry.static_correspondences.static_correspondences`), sought from
    the sample itself (``static``: only where the surfaces coincide) or from where
    the landmarks' interpolated 3D motion (:func:`landmark_motion`) predicts it
    (``guided``); the accepted ones join the landmarks of a new DMT fit (with
    ``pair.tolerant``, the landmarks' targets are the landmark fit's own images,
    not the given target landmarks). A fit that would fold unless smoothed is
    refused and the previous DMT kept.

    Parameters
    ----------
    pair : KeyPair
    z_prev : (p, 2) float64
        The consistent nodes on the source disk.
    cm_F : (f, 3) int64
    reg_d : DiskRegistration
        The landmark DMT, the first round's start.
    refine : ResolvedRefine
        Rounds, tolerance, guidance.
    options : RegistrationOptions
        ``static_samples``, ``static_max_disk_offset``, ``static_min_separation``.

    Returns
    -------
    registration : DiskRegistration
    accepted : list of int
        Correspondences accepted per round.
    rejected : bool
        A round's fit was refused.
    guide_degree : int or None
        Polynomial degree of the guide (None unguided).
    """
    from conformorph.geometry.static_correspondences import (
        StaticCorrespondenceOptions,
        farthest_point_samples,
        static_correspondences,
    )
    from conformorph.geometry.surface_distance import SurfaceDistance

    pa, pb = pair.source, pair.target
    P, Q = pa["lm_uv"], pb["lm_uv"]
    if pair.tolerant:  # the landmarks go where the (smoothing) landmark fit put them
        Q = np.asarray(reg_d.apply(P))
    Xa = pair.source_X
    r_uv = np.linalg.norm(pa["uv"], axis=1)
    near_lm = np.min(np.linalg.norm(pa["uv"][:, None, :] - P[None, :, :], axis=2), axis=1)
    cand = np.flatnonzero((r_uv < 0.95) & (near_lm > 0.02))
    samp = farthest_point_samples(Xa, options.static_samples, candidates=cand)
    sd = SurfaceDistance(pair.target_X, pb["F"])
    guide = np.zeros_like(Xa)
    guide_degree: int | None = None
    if refine.guided:
        # predicted 3D motion of every point: the landmarks' aligned displacement
        # interpolated in space
        guide, guide_degree = landmark_motion(pair.source_lm, pair.target_lm, Xa)
    accepted: list[int] = []
    for _ in range(refine.rounds):
        sc = static_correspondences(
            pa["uv"][samp],
            Xa[samp] + guide[samp],
            reg_d.apply(pa["uv"][samp]),
            pair.target_X,
            pb["F"],
            pb["uv"],
            StaticCorrespondenceOptions(
                tol=refine.tol,
                max_disk_offset=options.static_max_disk_offset,
                min_separation=options.static_min_separation,
            ),
            keep_away_source=P,
            keep_away_target=Q,
            target_distance=sd,
        )
        accepted.append(int(sc.accepted.sum()))
        if sc.source_uv.shape[0] == 0:
            break
        P2 = np.vstack([P, sc.source_uv])
        Q2 = np.vstack([Q, sc.target_uv])
        # a smoothed fit is rejected below anyway: do not try one (the same outcome,
        # without four more fits of every correspondence)
        refined = dmt_through(pair, P2, Q2, z_prev, cm_F, fold_regularizations=())
        if not meets_its_points(refined):
            # the extra correspondences cannot be met without smoothing away
            # the landmarks: keep the landmark-only DMT (reported)
            return reg_d, accepted, True, guide_degree
        reg_d = refined
    return reg_d, accepted, False, guide_degree


#: β per stiffness stage of the tolerant ICP (None: the default 10 throughout). Measured
#: on the Table 3 ICT path (``bench_face_tables.py --landmark-variants``, t = 0.3 … 1.5),
#: with the dense fit leaving the landmarks out: (10, 10, 1, 1, 1, 1), i.e. the full pull
#: until the retarget and a tenth of it on the corrected landmarks after, gives with
#: exact landmarks 1.02e-3, 1.07e-3, 5.2e-4, 6.6e-4 (10 throughout: 1.12e-3, 1.20e-3,
#: 5.3e-4, 6.6e-4) and keeps 3 mm perturbed landmarks within 2× of that on 6 of 8 noise
#: seeds (10 throughout: 4 of 8; the misses 2.05× and, where every fit on key pair 1→2
#: folded, 3.5–11.6×); fading further, (10, 10, 1, 0.1, 0.1, 0.1), folded the
#: composite map (refused) with auto-detected landmarks.
TOLERANT_LANDMARK_SCHEDULE: tuple[float, ...] | None = (10.0, 10.0, 1.0, 1.0, 1.0, 1.0)
#: Stiff stages after which the tolerant ICP's landmarks are retargeted to their closest
#: target points (:class:`conformorph.geometry.nonrigid_icp.NonrigidICPOptions`).
TOLERANT_RETARGET = 2
#: Whether the tolerant dense fit goes through the corrected landmarks too. They come from
#: the same ICP as its samples, so they add no information, only the ICP's distortion
#: where noisy landmarks pulled it. Table 3 ICT path, 3 mm perturbed landmarks, t = 0.3 …
#: 1.5: with them 1.14e-3, 1.20e-3, 1.24e-3, 1.79e-3 (on another noise seed 3.7e-3 at
#: t = 0.3); without them 1.09e-3, 1.12e-3, 8.1e-4, 1.08e-3 (before the sample radii
#: below, the fit through them folded at every count on both pairs: 6.3e-3 … 6.9e-3).
TOLERANT_FIT_LANDMARKS = False
#: Radii (disk units) within which the tolerant fit takes the ICP's samples, tried in
#: turn at every sample count before the count is halved. With imprecise landmarks the
#: samples nearest the rim are the least reliable and the fit through them folds the
#: rim band (Table 3 ICT path, key pair 1→2, 3 mm perturbed landmarks: 61 folded
#: triangles at |z| 0.96–0.99 at 0.95, every count down to 125; none at 0.9).
TOLERANT_SAMPLE_RADII = (0.95, 0.9, 0.85)

#: Weight of the target's mutual nearest vertices in the exact-landmark ICP's
#: correspondences from its fourth stage on
#: (:attr:`conformorph.geometry.nonrigid_icp.NonrigidICPOptions.vertex_pull`): closest
#: points leave the nodes free to slide along the surface (issue 27); where the keys sample
#: it alike, the target's vertices hold them. Off by default: measured on the corpus's
#: tuning split (``benchmarks/bench_face_corpus.py --split tune``, exact landmarks, with
#: :data:`DENSE_MIN_JACOBIAN` and the fallback of :func:`nicp_refinement`; per-vertex
#: mean / median / p95 mm, 0 → 0.5): ict_pair_0 0.83 / 0.49 / 2.78 → 0.70 / 0.37 / 2.68,
#: ict_pair_2 0.54 / 0.40 / 1.41 → 0.37 / 0.27 / 1.07, model3k_0 1.28 / 0.49 / 4.91 → 0.87 /
#: 0.27 / 4.00, model3k_4 2.14 / 0.82 / 9.11 → 1.81 / 0.60 / 7.57, ict_retri_1 0.95 / 0.55 /
#: 3.34 → 0.81 / 0.42 / 3.09, choi_warp_0 0.17 / 0.09 / 0.42 → 0.13 / 0.06 / 0.36: mean and
#: median lower on 11 of the 14 cases, the other 3 (ict_pair_1, ict_open60_0, ict_graded_0)
#: fall back to the unpulled ICP and are unchanged; p95 up by at most 0.03 mm (model3k_1
#: 2.65 → 2.68), surface error mean at most 1e-4 mm higher. On the Table 3 paths
#: (``benchmarks/bench_face_tables.py``, relative L2 at t = 0.3, 0.5, 1.3, 1.5) 0.5 lowers
#: every figure of the default homotopy (screened; curved 9.01e-4, 9.07e-4, 4.57e-4,
#: 6.47e-4 → 8.79e-4, 8.80e-4, 4.51e-4, 6.44e-4) and of metric, but raises some of the
#: others': vector at t = 0.3, 0.5 on both paths (linear: 5.89e-4 → 6.77e-4, 6.58e-4 →
#: 7.02e-4; curved: 1.27e-3 → 1.33e-3, 1.21e-3 → 1.26e-3), scalar on the curved path at
#: t = 0.3, 1.3, 1.5 (7.37e-3 → 7.70e-3 at 1.5) and on the linear path at t = 0.5, 1.3
#: (8.38e-3 → 8.56e-3 at 1.3), so the pull stays off until the lead decides. 0.7 was lower
#: still on some corpus cases (model3k_0 0.66 / 0.23 / 2.96) but raised ict_open60_0's p95 to 3.89.
EXACT_VERTEX_PULL = 0.0
#: With the vertex pull, the dense moves (nodes to their own ICP correspondences) must not
#: bring a consistent triangle's Jacobian (next disk against previous) below this, nor
#: below the fit's own (:func:`conformorph.geometry.fold_free_offsets.fold_free_offsets`;
#: without the pull only folds are dropped, as before): with the vertex pull a pair of the
#: tuning split left Jacobians of 1.8e-3 and 4.7e-4 (composite, model3k_1) and the Möbius
#: carry-back of key 2's disk to key 0's flipped one (refused); with 0.02 the smallest is
#: 0.065 / 0.024 and the morph runs.
DENSE_MIN_JACOBIAN = 0.02


def _corrected_landmarks(
    pair: KeyPair, res: Any, at: Any, cm_F: NDArray[np.int64], Xt: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(m, 2) where the ICP carried the source landmarks: their deformed positions' closest
    points on key i (``Xt``, key i in key i − 1's frame), on key i's disk."""
    from conformorph.geometry.surface_distance import SurfaceDistance, projected_barycentrics

    pb = pair.target
    Y = np.einsum("mj,mjk->mk", at.barycentric, res.deformed[cm_F[at.triangle]])
    c, _, tri = SurfaceDistance(Xt, pb["F"]).closest_triangles(Y, k=8)
    bary = projected_barycentrics(c, Xt[pb["F"][tri]])
    return np.asarray(np.einsum("mj,mjk->mk", bary, pb["uv"][pb["F"][tri]]))


def _nicp_deformation(
    pair: KeyPair,
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    reg_d: Any,
    icp_iterations: int,
    vertex_pull: float = 0.0,
) -> tuple[Any, Any, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], Any]:
    """The consistent nodes on key i − 1 deformed onto key i by non-rigid ICP.

    Returns the similarity G (key i onto key i − 1, with scale), the ICP result,
    the nodes' source positions Xs (p, 3), their closest points' disk positions on
    key i q_all (p, 2), the inner-node weights (p,) and the landmarks' corrected disk
    positions on key i (m, 2; with ``pair.tolerant``, where the ICP carried them,
    its landmark pull weighted by confidence and fading,
    :data:`TOLERANT_LANDMARK_SCHEDULE`; else the given ones).
    """
    from conformorph.geometry.nonrigid_icp import ICPLandmarks, NonrigidICPOptions, nonrigid_icp
    from conformorph.geometry.point_location import PointLocator
    from conformorph.geometry.rigid_alignment import RigidAlignmentOptions, rigid_landmark_alignment

    pa, pb = pair.source, pair.target
    Xa, Xb = pair.source_X, pair.target_X
    loc_a, loc_b = pair.source_locator, pair.target_locator
    P, Q = pa["lm_uv"], pb["lm_uv"]
    la = loc_a.locate(P).interpolate(pa["F"], Xa)
    lb = loc_b.locate(Q).interpolate(pb["F"], Xb)
    G, _ = rigid_landmark_alignment(
        lb,
        la,
        source_surface=Xb,
        target_surface=Xa,
        options=RigidAlignmentOptions(with_scale=True, icp_iterations=icp_iterations),
    )
    Xt = G.apply(Xb)
    Xs = loc_a.locate(z_prev).interpolate(pa["F"], Xa)
    at = PointLocator(z_prev, cm_F).locate(P)
    # reg_d and the refit below were checked for folds on z_prev: their images are kept
    z0 = reg_d.apply(z_prev) if reg_d.check_image is None else reg_d.check_image
    d0 = loc_b.locate(z0).interpolate(pb["F"], Xt) - Xs
    inner = (np.linalg.norm(z_prev, axis=1) < 0.95).astype(np.float64)
    tolerant = pair.tolerant
    res = nonrigid_icp(
        Xs,
        cm_F,
        Xt,
        pb["F"],
        ICPLandmarks(
            at.triangle, at.barycentric, G.apply(lb), pair.landmark_weights() if tolerant else None
        ),
        initial_displacement=d0,
        weights=inner,
        options=NonrigidICPOptions(
            landmark_schedule=TOLERANT_LANDMARK_SCHEDULE, landmark_retarget=TOLERANT_RETARGET
        )
        if tolerant
        else NonrigidICPOptions(vertex_pull=vertex_pull),
    )
    q_all = np.einsum("kj,kjd->kd", res.barycentric, pb["uv"][pb["F"][res.triangle]])
    q_lm = _corrected_landmarks(pair, res, at, cm_F, Xt) if tolerant else Q
    return G, res, Xs, q_all, inner, q_lm


def _fit_through_samples(
    pair: KeyPair,
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    reg_d: Any,
    samples: tuple[list[NDArray[np.int64]], NDArray[np.float64]],
    regularization: float,
    Q: NDArray[np.float64],
) -> tuple[Any, list[int]]:
    """The DMT through the landmarks (source → ``Q`` on key i's disk) and the ICP's samples,
    halved while it folds.

    ``samples`` is ``(ladder, q_all)``: node ids in farthest-point order, one array per
    sample radius (one for the exact fit; :data:`TOLERANT_SAMPLE_RADII` for the
    tolerant one, which also leaves the landmarks out when
    :data:`TOLERANT_FIT_LANDMARKS` is False), and every node's closest point on key i's
    disk. At every count, each array of the ladder is tried in turn.

    Returns the fit (``reg_d`` when every count from the first array's size down to 125
    folds) and the counts tried.
    """

    ladder, q_all = samples
    P = pair.source["lm_uv"]
    if pair.tolerant and not TOLERANT_FIT_LANDMARKS:
        P, Q = P[:0], Q[:0]
    tried: list[int] = []
    k = ladder[0].size
    while k >= 125:
        for ids in ladder:
            tried.append(int(min(k, ids.size)))
            P2 = np.vstack([P, z_prev[ids[:k]]])
            Q2 = np.vstack([Q, q_all[ids[:k]]])
            refined = dmt_through(
                pair,
                P2,
                Q2,
                z_prev,
                cm_F,
                # Tikhonov ε: the exact interpolant through ~10³ nodes folds at every
                # count tried (measured on the ICT Table 3 pairs); with ε = 1e-8 the
                # landmarks are met to E_D ~1e-5 (1.8e-3 on ICT neutral→jawOpen)
                regularization=regularization,
                max_steps=4,
                fold_regularizations=(),  # a smoothed fit is rejected anyway: do not try one
            )
            if meets_its_points(refined):
                return refined, tried
        k //= 2
    return reg_d, tried


def nicp_refinement(
    pair: KeyPair,
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    reg_d: Any,
    options: RegistrationOptions,
) -> tuple[Any, NDArray[np.float64], dict[str, Any]]:
    """Dense DMT correspondences of pair (i − 1, i) by non-rigid ICP (``refine="nicp"``).

    The consistent nodes carried to key i − 1 (``z_prev`` on its disk, a mesh with
    the consistent triangles) are deformed onto key i's surface by
    :func:`conformorph.geometry.nonrigid_icp.nonrigid_icp`, starting from the landmark DMT
    ``reg_d`` and pinned at the landmarks. Key i is first brought onto key i − 1 by a
    similarity (rigid landmarks and ICP, *with* scale): an expression changes the
    diameter (jawOpen: +5 %), so the diameter-normalised surfaces differ by a scale.
    Up to ``options.nicp_correspondences`` farthest-point samples of the nodes that
    end within ``options.nicp_tol`` of the target become extra DMT landmarks (node →
    closest point's position on key i's disk), fitted with Tikhonov
    ``options.extra_regularization``; while that fit folds (composed steps up to 4
    allowed, no smoothing), half as many are tried (down to 125), else ``reg_d`` (the
    landmark DMT) is kept. With ``pair.tolerant`` the fit leaves the landmarks out
    (:data:`TOLERANT_FIT_LANDMARKS`) and, at every count, tries the samples within each
    radius of :data:`TOLERANT_SAMPLE_RADII` in turn.

    The fit is smooth between its samples; then every node that ended within the
    tolerance of key i's surface is moved from the fit's image to its own closest
    point's disk position, except where that would fold a consistent triangle
    (:func:`conformorph.geometry.fold_free_offsets.fold_free_offsets` drops those moves with a
    one-ring margin). Measured on the Table 3 curved ICT sequence
    (``benchmarks/bench_nicp_variants.py``, with the earlier 18-iteration ICP schedule):
    DMT/identity at t = 1.3, 1.5 from 1.20, 1.28 (fit only) to 1.19, 1.24; without
    this step the current schedule gives 1.26, 1.39 against 1.18, 1.21 with it. The
    moves also keep every Jacobian above :data:`DENSE_MIN_JACOBIAN` (or the fit's own).

    With exact landmarks the ICP's final stages also pull the nodes towards the target's
    mutual nearest vertices (:data:`EXACT_VERTEX_PULL`), which holds them where the keys
    sample the surface alike instead of letting them slide. Should every fit through
    those samples fold at the first count, the ICP is run again without the pull and the
    attempt whose fit took more samples (then: put more nodes on their own
    correspondences) is kept.

    Parameters
    ----------
    pair : KeyPair
    z_prev : (p, 2) float64
        The consistent nodes on the source disk.
    cm_F : (f, 3) int64
    reg_d : DiskRegistration
        The landmark DMT.
    options : RegistrationOptions
        ``icp_iterations``, ``nicp_correspondences``, ``nicp_tol``, ``extra_regularization``.

    Returns
    -------
    registration : DiskRegistration
        The refined DMT (or ``reg_d``): the map of the landmarks and of every point
        other than the nodes.
    z_next : (p, 2) float64
        The nodes' positions on key i's disk: the registration's image, moved to the
        closest points where that folds nothing.
    meta : dict
        ``correspondences`` (used), ``candidates``, ``tried`` (counts tried),
        ``dense_nodes`` (nodes on their own closest point), ``dense_dropped`` (nodes
        whose move was dropped), ``scale`` (of the similarity), ``icp_rms_distance``,
        ``matched``, ``corrected_landmark_shift`` (rms disk distance of the landmarks'
        corrected target positions to the given ones; 0 with exact landmarks),
        ``corrected_landmarks`` (with ``pair.tolerant``: (m, 3) list, where the ICP
        carried key i − 1's landmarks on key i, in key i's input coordinates),
        ``vertex_pull`` (of the kept attempt), ``vertex_pull_fallback`` (the attempt
        without the pull was kept), ``attempts`` (``[correspondences, dense_nodes]`` of
        every attempt, the pulled one first), ``seconds``.
    """
    t0 = time.perf_counter()
    first = 0.0 if pair.tolerant else EXACT_VERTEX_PULL
    out, z_next, meta = _nicp_attempt(pair, z_prev, cm_F, reg_d, options, first)
    attempts = [(meta["correspondences"], meta["dense_nodes"])]
    if first > 0 and (out is reg_d or len(meta["tried"]) > 1):
        # the fit through the pulled ICP's samples folded at the first count: the ICP
        # again with closest points only (its samples are the smoother); kept is the
        # attempt whose fit took more samples, then put more nodes on their own
        # correspondences (a tie keeps the pulled one)
        other = _nicp_attempt(pair, z_prev, cm_F, reg_d, options, 0.0)
        attempts.append((other[2]["correspondences"], other[2]["dense_nodes"]))
        if attempts[1] > attempts[0]:
            out, z_next, meta = other
    meta["vertex_pull_fallback"] = meta["vertex_pull"] != first
    meta["attempts"] = [list(a) for a in attempts]
    meta["seconds"] = time.perf_counter() - t0
    return out, z_next, meta


def _nicp_attempt(
    pair: KeyPair,
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    reg_d: Any,
    options: RegistrationOptions,
    vertex_pull: float,
) -> tuple[Any, NDArray[np.float64], dict[str, Any]]:
    """One :func:`nicp_refinement` with the ICP's vertex pull ``vertex_pull`` (its
    ``meta`` without ``seconds`` and ``vertex_pull_fallback``)."""
    from conformorph.geometry.fold_free_offsets import fold_free_offsets
    from conformorph.geometry.map_jacobian import map_jacobian_determinants
    from conformorph.geometry.static_correspondences import farthest_point_samples

    G, res, Xs, q_all, inner, q_lm = _nicp_deformation(
        pair, z_prev, cm_F, reg_d, options.icp_iterations, vertex_pull
    )
    close = res.matched & (inner > 0) & (res.distance <= options.nicp_tol)
    cand = np.flatnonzero(close)
    radii = TOLERANT_SAMPLE_RADII if pair.tolerant else (1.0,)
    r_cand = np.linalg.norm(z_prev[cand], axis=1)
    ladder = [
        farthest_point_samples(Xs, options.nicp_correspondences, candidates=cand[r_cand < r])
        for r in radii
    ]
    out, tried = _fit_through_samples(
        pair, z_prev, cm_F, reg_d, (ladder, q_all), options.extra_regularization, q_lm
    )
    used = tried[-1] if out is not reg_d else 0
    # the thin-plate fit through the samples is smooth between them; every node that
    # ended on key i's surface takes its own closest point instead, except where that
    # would fold a consistent triangle
    z_fit = out.apply(z_prev) if out.check_image is None else out.check_image
    z_next, n_dense, n_dropped = z_fit, 0, 0
    # a fit that folds is refused by the caller's composite check; nothing to add to it
    if np.all(map_jacobian_determinants(z_prev, z_fit, cm_F) > 0):
        offsets = np.where(close[:, None], q_all - z_fit, 0.0)
        floor = DENSE_MIN_JACOBIAN if vertex_pull > 0 else 0.0
        dense = fold_free_offsets(z_prev, z_fit, offsets, cm_F, min_jacobian=floor)
        z_next = z_fit + dense.offsets
        n_dense, n_dropped = int((close & ~dense.dropped).sum()), int(dense.dropped.sum())
    return (
        out,
        z_next,
        {
            "dense_nodes": n_dense,
            "dense_dropped": n_dropped,
            "correspondences": used,
            "candidates": int(cand.size),
            "tried": tried,
            "scale": float(G.scale),
            "icp_rms_distance": res.history[-1]["rms_distance"],
            "matched": int(res.matched.sum()),
            "corrected_landmark_shift": float(
                np.sqrt(np.mean(np.sum((q_lm - pair.target["lm_uv"]) ** 2, axis=1)))
            ),
            "corrected_landmarks": (
                pair.target_locator.locate(q_lm).interpolate(pair.target["F"], pair.target["V"])
            ).tolist()
            if pair.tolerant
            else None,
            "vertex_pull": vertex_pull,
        },
    )
