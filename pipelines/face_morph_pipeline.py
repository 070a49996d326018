"""The face morphing pipeline (sections 3–5 of the face paper), split into stages.

Stages, each a function whose inputs and outputs are plain dicts of numpy
arrays (saved with :func:`save_stage` / :func:`load_stage` as ``.npz``, so
that a Celery worker can run them as separate tasks; JSON diagnostics ride in
the ``"meta_json"`` entry):

1. :func:`prepare_mesh` (one per input mesh, independent): validate,
   normalise by diameter, disk conformal map, H, Hn, λ, landmarks on the
   surface and on the disk.
2. :func:`register_meshes`: rigid alignment to the first mesh (landmarks,
   trimmed, plus ICP on the rigid part), pairwise disk registration
   (MT/DMT/identity) with fold guard, composite maps on a consistent mesh,
   resampling of every key's data there; E_D and E (eqs. 2, 3).
3. :func:`compute_frames`: the spline homotopy and reconstruction of every
   frame, the rigid part interpolated apart; metrics at the keys (and
   against true surfaces when given) for the method and the baselines.
4. :func:`export_outputs`: ``animation.glb``, optional ``frames/NNN.glb``,
   ``metrics.json``.

:func:`run_face_morph` runs them in order.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipelines.jsonable import jsonable

Arrays = dict[str, Any]
ProgressFn = Callable[[float, str], None]

METHODS = ("dmt", "mt", "identity", "linear")
CURVATURE_HOMOTOPIES = ("vector", "scalar", "metric", "screened")
#: the default curvature homotopy, chosen by measurement (benchmarks/bench_face_tables.py)
DEFAULT_CURVATURE = "screened"
#: Dense correspondences per pair taken from the non-rigid ICP of ``refine="nicp"``
#: (halved while the DMT fit through them folds).
NICP_CORRESPONDENCES = 1000
#: Largest distance (diameters) of an ICP-deformed node to the target surface for its
#: closest point to be used as a correspondence.
NICP_TOL = 2e-3
#: Largest consistent mesh (nodes) on which ``refine="auto"`` (the default) runs the
#: non-rigid ICP; above it, the guided closest points. Measured with
#: ``benchmarks/bench_face_speed.py``: two ICT faces (7k nodes) 2.2 s end to end with
#: "nicp" (median of 5), 1.0 s with "guided"; two 68k-node faces 55 s with "nicp"
#: (registration 34 s, most of it the ICP's bi-Laplacian factorisations; the frames'
#: solves 17 s, slower on its dense correspondences), 11.7 s with "guided".
NICP_AUTO_MAX_NODES = 20_000


class InputMismatchError(ValueError):
    """Inputs that cannot be combined (e.g. ``identity`` with different connectivity)."""

    code = "input_mismatch"


# --------------------------------------------------------------------------- stage I/O


def save_stage(path: str | Path, arrays: Arrays) -> None:
    """Save a stage's dict of arrays as ``.npz`` (``meta`` dicts as JSON)."""
    out: dict[str, NDArray[Any]] = {}
    for k, v in arrays.items():
        if k == "meta":
            out["meta_json"] = np.array(json.dumps(jsonable(v)))
        else:
            out[k] = np.asarray(v)
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, **out)  # type: ignore[arg-type]
    tmp.replace(p)


def load_stage(path: str | Path) -> Arrays:
    """Load a stage saved by :func:`save_stage`."""
    with np.load(path, allow_pickle=False) as z:
        d: Arrays = {k: z[k] for k in z.files}
    if "meta_json" in d:
        d["meta"] = json.loads(str(d.pop("meta_json")))
    return d


# --------------------------------------------------------------------------- stage 1


def prepare_mesh(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    landmark_entries: list[Any],
    *,
    mesh_index: int = 0,
    disk_method: str = "fast",
    tex_uv: NDArray[np.float64] | None = None,
    colors: NDArray[np.float64] | None = None,
    texture: NDArray[np.uint8] | None = None,
) -> Arrays:
    """Stage 1 for one mesh: validation, normalisation, disk map, H, Hn, λ, landmarks.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    landmark_entries : list
        Vertex indices or [x, y, z] points (see :mod:`pipelines.landmarks_io`).
    mesh_index : int
        Position among the inputs (error messages).
    disk_method : str
        Passed to :func:`geometry.disk_conformal_map`.
    tex_uv : (n, 2) float64, optional
        Texture coordinates of the mesh (OBJ convention, origin bottom left),
        resampled with everything else.
    colors : (n, 3) float64, optional
        Per-vertex colours in [0, 1].
    texture : (h, w, 3) uint8, optional
        The texture image ``tex_uv`` points into (needs ``tex_uv``).

    Returns
    -------
    dict of arrays
        ``V, F, Vn, uv, lam, H, Hn, lm_tri, lm_bary, lm_uv, lm_points,
        lm_snap, norm_translation, norm_scale`` (+ ``tex_uv``, ``colors``,
        ``texture``) and ``meta`` (disk-map diagnostics, seconds).

    Raises
    ------
    FoldedMapError
        When the disk map keeps folded triangles after its fold repair
        (:func:`geometry.disk_conformal_map`, ``fold_policy="repair"``): the
        mesh and the count are named; nothing folded is passed on.
    """
    from geometry import (
        conformal_factor,
        disk_conformal_map,
        mean_curvature,
        mean_curvature_vector,
        validate_mesh,
    )
    from geometry.rigid_alignment import normalize_by_diameter
    from pipelines.landmarks_io import resolve_landmarks

    t0 = time.perf_counter()
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    report = validate_mesh(V, F, require_disk=True)
    n = V.shape[0]
    if tex_uv is not None:
        tex_uv = np.asarray(tex_uv, dtype=np.float64)
        if tex_uv.shape != (n, 2) or not np.all(np.isfinite(tex_uv)):
            raise ValueError(
                f"mesh {mesh_index}: tex_uv must be a finite ({n}, 2) array, got {tex_uv.shape}"
            )
    if texture is not None:
        texture = np.asarray(texture)
        if tex_uv is None:
            raise ValueError(f"mesh {mesh_index}: a texture needs texture coordinates (tex_uv)")
        if texture.dtype != np.uint8 or texture.ndim != 3 or texture.shape[2] != 3:
            raise ValueError(
                f"mesh {mesh_index}: texture must be an (h, w, 3) uint8 image, got "
                f"{texture.dtype} {texture.shape}"
            )
    if colors is not None:
        colors = np.asarray(colors, dtype=np.float64)
        if colors.shape != (n, 3) or not np.all((colors >= 0) & (colors <= 1)):
            raise ValueError(
                f"mesh {mesh_index}: colors must be ({n}, 3) in [0, 1], got {colors.shape}"
            )
    lms = resolve_landmarks(landmark_entries, V, F, mesh_index=mesh_index)
    Vn, N = normalize_by_diameter(V)
    t1 = time.perf_counter()
    # the harmonic map itself, not the angle-refined one: the frames are rebuilt
    # with the disk's cotangent Laplacian, which reproduces the surface where the
    # map is harmonic for it (flat disk: 4e-7 of its size, 2e-4 after the angle
    # refinement; see geometry.disk_conformal_map's refine_angles)
    uv, info = disk_conformal_map(Vn, F, method=disk_method, refine_angles=False)  # type: ignore[arg-type]
    if info.flipped:
        # never carry a folded disk map on: every later map and frame would fold with it
        from geometry.flipped_triangles import flipped_triangles
        from geometry.mesh_errors import FoldedMapError

        bad = np.flatnonzero(flipped_triangles(uv, F))
        raise FoldedMapError(
            f"mesh {mesh_index}: the disk map still has {int(info.flipped)} folded triangles "
            f"after the fold repair ({int(info.flipped_before_repair)} before it; faces "
            f"{bad[:8].tolist()}); the surface probably folds over itself or has "
            "near-degenerate triangles there: repair the mesh and retry"
        )
    t2 = time.perf_counter()
    lam = conformal_factor(Vn, F, uv)
    H = mean_curvature(Vn, F)
    Hn = mean_curvature_vector(Vn, F)
    lm_uv = np.einsum("mj,mjk->mk", lms.barycentric, uv[F[lms.triangle]])
    lm_points = np.einsum("mj,mjk->mk", lms.barycentric, Vn[F[lms.triangle]])
    out: Arrays = {
        "V": V,
        "F": F,
        "Vn": Vn,
        "uv": uv,
        "lam": lam,
        "H": H,
        "Hn": Hn,
        "lm_tri": lms.triangle,
        "lm_bary": lms.barycentric,
        "lm_uv": lm_uv,
        "lm_points": lm_points,
        "lm_snap": lms.snap_distance,
        "norm_translation": N.translation,
        "norm_scale": np.array(N.scale),
    }
    if tex_uv is not None:
        out["tex_uv"] = tex_uv
    if colors is not None:
        out["colors"] = colors
    if texture is not None:
        out["texture"] = texture
    out["meta"] = {
        "mesh_index": mesh_index,
        "n_vertices": int(V.shape[0]),
        "n_faces": int(F.shape[0]),
        "boundary_loops": int(getattr(report, "boundary_loops", 1)),
        "diameter": float(N.scale),
        "disk_map": {
            "method": info.method,
            "flipped": int(info.flipped),
            "flipped_before_repair": int(info.flipped_before_repair),
            "repaired_vertices": int(info.repaired_vertices),
            "boundary_circle_error": float(info.boundary_circle_error),
        },
        "landmark_snap_distance_max": float(lms.snap_distance.max()),
        "seconds": {
            "validate_and_landmarks": t1 - t0,
            "disk_map": t2 - t1,
            "curvature": time.perf_counter() - t2,
        },
    }
    return out


# --------------------------------------------------------------------------- stage 2


def _similarity(R: Any, t: Any, s: Any) -> Any:
    from geometry.rigid_alignment import SimilarityTransform

    return SimilarityTransform(np.asarray(R), np.asarray(t), float(s))


def register_meshes(
    prepared: Sequence[Arrays],
    *,
    method: str = "dmt",
    consistent: str = "source",
    target_vertices: int | None = None,
    icp_iterations: int = 10,
    baselines: bool = True,
    curvature_source: str = "consistent",
    refine: str = "auto",
    static_refinement: int | None = None,
    static_tol: float | None = None,
    static_samples: int = 400,
    static_max_disk_offset: float = 0.05,
    static_min_separation: float = 0.02,
    static_guided: bool | None = None,
    extra_correspondences: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None,
    extra_regularization: float = 1e-8,
    nicp_correspondences: int = NICP_CORRESPONDENCES,
    nicp_tol: float = NICP_TOL,
    nicp_max_nodes: int = NICP_AUTO_MAX_NODES,
) -> Arrays:
    """Stage 2: rigid alignment, disk registration, composite maps, consistent-mesh resampling.

    Parameters
    ----------
    prepared : sequence of stage-1 dicts
        In key order (N + 1 ≥ 2 meshes).
    method : {"dmt", "mt", "identity", "linear"}
        Registration of the homotopy (``linear`` registers by DMT).
    consistent : {"source", "landmarks"}
        Consistent mesh: the first input's own mesh, or the paper's refined
        landmark mesh.
    target_vertices : int, optional
        Resolution of the landmark mesh (default: first input's vertex count).
    icp_iterations : int
        ICP refinement of the rigid alignment.
    baselines : bool
        Also build the MT keys (for the MT-only baseline).
    curvature_source : {"consistent", "resampled"}
        Key curvature and conformal factor computed on each key's consistent
        mesh (default), or resampled from the input's per-vertex values.
    refine : {"auto", "nicp", "guided", "static", "none"}
        Extra DMT correspondences beyond the landmarks (an extension of the
        paper, whose DMT uses the landmarks only: ``"none"``). ``"auto"``
        (default): ``"nicp"`` on consistent meshes of at most ``nicp_max_nodes``
        nodes, ``"guided"`` on larger ones, where the ICP costs more than the
        rest of the morph (see :data:`NICP_AUTO_MAX_NODES`); the preset used
        is reported as ``meta["refine"]["used"]``. ``"nicp"``: from the
        landmark DMT (starting from the guided one measured the same), the consistent nodes
        carried to key i − 1 are deformed onto key i's surface by non-rigid
        ICP (:mod:`geometry.nonrigid_icp`: the smoothest bi-Laplacian
        displacement on the source surface that carries them onto the target
        and the landmarks onto the landmarks, key i first brought onto key
        i − 1 by a similarity with scale) and ``nicp_correspondences``
        farthest-point samples of the nodes that end within ``nicp_tol`` of
        the target become extra DMT landmarks (halved while the fit folds;
        the landmark DMT is kept when every count folds; reported per pair as
        ``nicp``); the nodes that ended on the target then take their own
        closest points wherever that folds nothing (``dense_nodes``).
        Measured on the ICT Table 3 sequence (curved path, screened homotopy,
        ``benchmarks/bench_nicp_variants.py``): DMT/identity error 0.98, 1.01,
        1.18, 1.21 at t = 0.3, 0.5, 1.3, 1.5 against 1.15, 1.28, 2.07, 1.78
        for "guided"; two ICT faces end to end 2.2 s, against 1.0 s with
        "guided" (``benchmarks/bench_face_speed.py``, medians).
        ``"guided"``: one round of
        closest points sought from where the
        landmarks' interpolated 3D motion predicts each sample (tolerance
        5e-3 diameters); ``"static"``: one round of plain closest points
        (tolerance 3e-3), i.e. only where the surfaces coincide. Extra
        correspondences that would make the map fold unless smoothed are
        dropped (reported). Measured on the ICT Table 3 sequence
        (``benchmarks/bench_face_tables.py``): "guided" lowers DMT's error
        against the true in-between surfaces from 5.0e-3–1.3e-2 to
        3.4e-3–4.7e-3 (curved path, metric homotopy; screened homotopy:
        1.2e-3–3.1e-3 to 0.7e-3–1.2e-3) and from 0.8e-3–1.9e-3 to 3–4e-4
        (linear path, metric). Its dense correspondence error against the
        known one is 3.6e-3 (key 1) and 7.7e-3 (key 2, composite) diameters
        rms, against 3.2e-3 and 1.2e-2 for landmarks only. The predicted
        motion is :func:`landmark_motion`: affine plus r kernel, or constant
        plus r kernel with 3 (or coplanar) landmarks (reported per pair as
        ``guide_polynomial_degree``). The ``static_*`` arguments override the
        preset.
    static_refinement : int
        Rounds of extra DMT correspondences on the parts of the aligned
        surfaces that coincide (:mod:`geometry.static_correspondences`);
        0 = the paper's landmark-only DMT.
    static_tol, static_samples, static_max_disk_offset, static_min_separation : float, int, float, float
        Its distance tolerance (in diameters), sample count, disk
        consistency bound and minimum disk separation of extra landmarks.
    static_guided : bool
        Look for the closest point from where the landmarks' interpolated 3D
        motion predicts the sample to be (deformation-guided closest points),
        instead of from the sample itself (static parts only).
    extra_correspondences : sequence of N pairs ((k, 2), (k, 2)) float64, optional
        Further corresponding points on the disks of each consecutive pair
        (mesh i − 1 → mesh i), e.g. semi-landmarks from another tool, added
        to the landmarks of that pair's DMT fit (with Tikhonov
        ``extra_regularization``) instead of the ``refine`` correspondences.
        A fit that can only avoid folding by smoothing is rejected (the
        landmark DMT is kept; reported as ``extra_rejected``).
    extra_regularization : float
        Tikhonov ε of the fit with extra correspondences (and with the
        ``"nicp"`` ones: that fit does not interpolate the landmarks exactly;
        measured E_D 1e-6–1e-5 on the test faces, 1.8e-3 on ICT
        neutral→jawOpen).
    nicp_correspondences : int
        Most extra correspondences per pair taken from the non-rigid ICP.
    nicp_tol : float
        Largest distance (diameters) of a deformed node to the target surface
        for it to give a correspondence.
    nicp_max_nodes : int
        Largest consistent mesh on which ``refine="auto"`` uses ``"nicp"``.

    Returns
    -------
    dict of arrays
        ``cm_uv, cm_F, cm_b``; per registration variant ``v`` (``main`` and,
        with baselines, ``mt``): ``key_uv__v (N+1, n, 2)``, ``key_X__v``
        (aligned, normalised positions), ``key_Hn__v``, ``key_H__v``,
        ``key_lam__v``, optional ``key_colors__v`` (when every input has
        vertex colours); ``key_R (N+1, 3, 3)``, ``key_t (N+1, 3)``,
        ``key_s (N+1,)``: similarities from the aligned frame back to each
        input; when every input has texture coordinates and a texture image:
        ``cm_tex_uv (n, 2)`` (the first input's texture coordinates resampled
        at the consistent nodes: the atlas layout), ``key_tex_uv (N+1, n, 2)``
        (each key's own texture coordinates there, through the composite
        map) and ``key_textures (N+1, H, W, 3) uint8`` (each key's texture
        rendered on the atlas layout, :func:`geometry.consistent_mesh.resample_texture`);
        ``meta`` (registration metrics).

    Raises
    ------
    InputMismatchError
        ``identity`` with inputs of different connectivity.
    FoldedMapError
        When the composite map of the homotopy's registration (variant
        ``main``) folds a consistent-mesh triangle for some key. Each pair's
        DMT is already kept bijective on the consistent nodes it moves
        (stepwise, regularised or MT fallback, reported per pair as
        ``dmt_fallback``), so this guards what the pair check cannot see:
        the resampling in each input's disk and an input disk map that folds.
        The MT baseline only feeds metrics; its folds are reported, not refused.
    """
    from geometry import mean_curvature, mean_curvature_vector
    from geometry.consistent_mesh import consistent_mesh
    from geometry.disk_registration import register_disk_landmarks
    from geometry.map_jacobian import fold_report
    from geometry.mesh_errors import FoldedMapError
    from geometry.point_location import PointLocator
    from geometry.registration_error import disk_registration_error
    from geometry.rigid_alignment import rigid_landmark_alignment
    from geometry.static_correspondences import farthest_point_samples, static_correspondences
    from geometry.surface_distance import SurfaceDistance

    presets = {
        "auto": (0, 3e-3, False),  # resolved below, once the consistent mesh is known
        "none": (0, 3e-3, False),
        "static": (1, 3e-3, False),
        "guided": (1, 5e-3, True),
        # the landmark DMT is the ICP's start and fallback: starting from the guided one
        # instead measured the same (bench_nicp_variants: 1.176, 1.212 against 1.178,
        # 1.208 at t = 1.3, 1.5) for 0.4 s more a pair
        "nicp": (0, 3e-3, False),
    }
    if refine not in presets:
        raise ValueError(f"refine must be one of {', '.join(presets)}, got {refine!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    n_keys = len(prepared)
    if n_keys < 2:
        raise ValueError(f"need at least 2 meshes, got {n_keys}")
    t0 = time.perf_counter()
    if method == "identity":
        F0 = prepared[0]["F"]
        for i, p in enumerate(prepared[1:], start=1):
            if p["F"].shape != F0.shape or not np.array_equal(p["F"], F0):
                raise InputMismatchError(
                    f"--method identity needs every input to share the first mesh's faces; "
                    f"mesh {i} has {p['V'].shape[0]} vertices / {p['F'].shape[0]} faces "
                    f"with a different faces array (mesh 0: {prepared[0]['V'].shape[0]} / "
                    f"{F0.shape[0]}). Use --method dmt or mt."
                )

    # rigid alignment of every normalised mesh onto mesh 0 (landmarks, trimmed, ICP)
    aligned_R, aligned_t = [np.eye(3)], [np.zeros(3)]
    rigid_meta: list[dict[str, Any]] = []
    for i in range(1, n_keys):
        G, info = rigid_landmark_alignment(
            prepared[i]["lm_points"],
            prepared[0]["lm_points"],
            source_surface=prepared[i]["Vn"],
            target_surface=prepared[0]["Vn"],
            icp_iterations=icp_iterations,
        )
        aligned_R.append(G.rotation)
        aligned_t.append(G.translation)
        rigid_meta.append(
            {
                "mesh": i,
                "rms_all": info.rms_all,
                "rms_rigid": info.rms_rigid,
                "n_rigid_landmarks": int(info.rigid.sum()),
                "icp_iterations": info.icp_iterations,
                "icp_rms": info.icp_rms,
            }
        )
    t_rigid = time.perf_counter()

    p0 = prepared[0]
    cm = consistent_mesh(
        p0["uv"], p0["F"], p0["lm_uv"], mode=consistent, target_vertices=target_vertices
    )
    locators = [PointLocator(p["uv"], p["F"]) for p in prepared]
    aligned = [p["Vn"] @ aligned_R[i].T + aligned_t[i] for i, p in enumerate(prepared)]
    used = refine
    if refine == "auto":
        used = "nicp" if cm.uv.shape[0] <= nicp_max_nodes else "guided"
    p_rounds, p_tol, p_guided = presets[used]
    static_refinement = p_rounds if static_refinement is None else static_refinement
    static_tol = p_tol if static_tol is None else static_tol
    static_guided = p_guided if static_guided is None else static_guided

    def lam_at(i: int, pts: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(locators[i].locate(pts).interpolate(prepared[i]["F"], prepared[i]["lam"]))

    reg_method = "dmt" if method in ("dmt", "linear") else "mt"
    main_is_mt = method == "mt"
    variants = ["main"] + (["mt"] if baselines and not main_is_mt else [])
    pair_meta: list[dict[str, Any]] = []
    # inverse MT of every pair, to express every key disk in the first one's Möbius frame
    unrotate: list[Any] = []
    # composite positions of the consistent nodes per variant
    composite: dict[str, list[NDArray[np.float64]]] = {v: [cm.uv] for v in variants}
    for i in range(1, n_keys):
        P = prepared[i - 1]["lm_uv"]
        Q = prepared[i]["lm_uv"]
        scale = lam_at(i, Q) / lam_at(i - 1, P)  # λ1²/λ0² of the paper = ratio of area factors
        # the map is checked where it is used: on the consistent nodes carried so far
        z_prev = composite["main"][-1]
        reg_d = register_disk_landmarks(
            P, Q, z_prev, cm.F, method="dmt", kernel_scale=scale, on_fold="fallback"
        )
        n_static: list[int] = []
        static_rejected = False
        guide_degree: int | None = None
        n_extra, extra_rejected = 0, False
        if extra_correspondences is not None and reg_method == "dmt":
            if len(extra_correspondences) != n_keys - 1:
                raise ValueError(
                    f"extra_correspondences needs one (source, target) pair per consecutive "
                    f"pair of meshes ({n_keys - 1}), got {len(extra_correspondences)}"
                )
            pe = np.asarray(extra_correspondences[i - 1][0], dtype=np.float64).reshape(-1, 2)
            qe = np.asarray(extra_correspondences[i - 1][1], dtype=np.float64).reshape(-1, 2)
            if pe.shape != qe.shape:
                raise ValueError(f"extra correspondences of pair {i}: {pe.shape} vs {qe.shape}")
            if pe.shape[0]:
                Pe, Qe = np.vstack([P, pe]), np.vstack([Q, qe])
                reg_e = register_disk_landmarks(
                    Pe,
                    Qe,
                    z_prev,
                    cm.F,
                    method="dmt",
                    kernel_scale=lam_at(i, Qe) / lam_at(i - 1, Pe),
                    regularization=extra_regularization,
                    on_fold="fallback",
                )
                if reg_e.fallback in (None, "stepwise"):
                    reg_d, n_extra = reg_e, int(pe.shape[0])
                else:
                    extra_rejected = True
        if reg_method == "dmt" and static_refinement > 0 and extra_correspondences is None:
            pa, pb = prepared[i - 1], prepared[i]
            r_uv = np.linalg.norm(pa["uv"], axis=1)
            near_lm = np.min(np.linalg.norm(pa["uv"][:, None, :] - P[None, :, :], axis=2), axis=1)
            cand = np.flatnonzero((r_uv < 0.95) & (near_lm > 0.02))
            samp = farthest_point_samples(aligned[i - 1], static_samples, candidates=cand)
            sd = SurfaceDistance(aligned[i], pb["F"])
            guide = np.zeros_like(aligned[i - 1])
            if static_guided:
                # predicted 3D motion of every point: the landmarks' aligned displacement
                # interpolated in space
                src = pa["lm_points"] @ aligned_R[i - 1].T + aligned_t[i - 1]
                dst = pb["lm_points"] @ aligned_R[i].T + aligned_t[i]
                guide, guide_degree = landmark_motion(src, dst, aligned[i - 1])
            for _ in range(static_refinement):
                sc = static_correspondences(
                    pa["uv"][samp],
                    aligned[i - 1][samp] + guide[samp],
                    reg_d.apply(pa["uv"][samp]),
                    aligned[i],
                    pb["F"],
                    pb["uv"],
                    tol=static_tol,
                    max_disk_offset=static_max_disk_offset,
                    min_separation=static_min_separation,
                    keep_away_source=P,
                    keep_away_target=Q,
                    target_distance=sd,
                )
                n_static.append(int(sc.accepted.sum()))
                if sc.source_uv.shape[0] == 0:
                    break
                P2 = np.vstack([P, sc.source_uv])
                Q2 = np.vstack([Q, sc.target_uv])
                scale2 = lam_at(i, Q2) / lam_at(i - 1, P2)
                refined = register_disk_landmarks(
                    P2, Q2, z_prev, cm.F, method="dmt", kernel_scale=scale2, on_fold="fallback"
                )
                if refined.fallback not in (None, "stepwise"):
                    # the extra correspondences cannot be met without smoothing away
                    # the landmarks: keep the landmark-only DMT (reported)
                    static_rejected = True
                    break
                reg_d = refined
        nicp_meta: dict[str, Any] | None = None
        z_next: NDArray[np.float64] | None = None  # the nodes' own images, when dense
        if reg_method == "dmt" and used == "nicp" and extra_correspondences is None:
            reg_d, z_next, nicp_meta = _nicp_refinement(
                prepared[i - 1],
                prepared[i],
                aligned[i - 1],
                aligned[i],
                locators[i - 1],
                locators[i],
                z_prev,
                cm.F,
                reg_d,
                lam_at,
                i,
                icp_iterations=icp_iterations,
                n_correspondences=nicp_correspondences,
                tol=nicp_tol,
                regularization=extra_regularization,
            )
        reg_m = register_disk_landmarks(P, Q, z_prev, cm.F, method="mt")
        unrotate.append(reg_m.mobius.inverse())
        e_dmt = _surface_error(prepared[i], locators[i], reg_d.apply(P))
        e_mt = _surface_error(prepared[i], locators[i], reg_m.apply(P))
        pair_meta.append(
            {
                "pair": [i - 1, i],
                "E_D": {
                    "mt": reg_m.error_disk,
                    "dmt": disk_registration_error(reg_d.apply(P), Q),
                },
                "E": {"mt": e_mt, "dmt": e_dmt},
                "dmt_fallback": reg_d.fallback,
                "static_correspondences": n_static,
                "static_refinement_rejected": static_rejected,
                "nicp": nicp_meta,
                "guide_polynomial_degree": guide_degree,
                "extra_correspondences": n_extra,
                "extra_rejected": extra_rejected,
                "dmt_attempts": reg_d.attempts,
                "min_jacobian": {
                    "mt": reg_m.fold.min_jacobian_determinant if reg_m.fold else None,
                    "dmt": reg_d.fold.min_jacobian_determinant if reg_d.fold else None,
                },
                "folded_triangles": {
                    "mt": reg_m.fold.n_folded if reg_m.fold else None,
                    "dmt": reg_d.fold.n_folded if reg_d.fold else None,
                },
                "mobius": {
                    "a": [reg_m.mobius.a.real, reg_m.mobius.a.imag],
                    "theta": reg_m.mobius.theta,
                },
            }
        )
        for v in variants:
            zp = composite[v][-1]
            if v == "mt":
                composite[v].append(reg_m.apply(zp))
            elif method == "identity":
                composite[v].append(zp)  # unused: identity resamples through the shared faces
            elif v == "main" and z_next is not None:
                composite[v].append(z_next)
            elif v == "main" and reg_method == "dmt" and reg_d.check_image is not None:
                composite[v].append(reg_d.check_image)  # reg_d was checked on zp = z_prev
            else:
                composite[v].append((reg_d if reg_method == "dmt" else reg_m).apply(zp))
    t_reg = time.perf_counter()

    out: Arrays = {"cm_uv": cm.uv, "cm_F": cm.F, "cm_b": cm.b}
    loc0 = locators[0].locate(cm.uv)
    has_tex = ["tex_uv" in p and "texture" in p for p in prepared]
    if any(has_tex) and not all(has_tex):
        raise ValueError(
            "textures need texture coordinates and an image for every mesh; missing for mesh "
            + ", ".join(str(i) for i, h in enumerate(has_tex) if not h)
        )
    with_colors = all("colors" in p for p in prepared)
    key_tex_uv: list[NDArray[np.float64]] = []
    composite_folds: dict[str, list[int]] = {}
    composite_min_jac: dict[str, list[float]] = {}
    for v in variants:
        key_uv, key_X, key_Hn, key_H, key_lam, key_col = [], [], [], [], [], []
        for i, p in enumerate(prepared):
            R, tr = aligned_R[i], aligned_t[i]
            if method == "identity" and v == "main":
                loc = loc0  # same (triangle, barycentric) in every mesh: the oracle correspondence
            else:
                loc = locators[i].locate(composite[v][i])
            Fi = p["F"]
            # disk maps are unique only up to a disk automorphism, and each input's is
            # normalised on its own (a reordered copy can come out rotated by 100°);
            # the homotopy of disk positions D(q, t) must not sweep through that
            # Möbius difference, so key i's disk is carried back by the inverse MTs of
            # pairs i, i − 1, …, 1 (λ transforms with it)
            # the disk positions are the composite map's own images: a point in the
            # sliver between a boundary chord of key i's disk mesh and its arc has no
            # triangle, and its data (below) come from the nearest point of the mesh,
            # but moving the point itself onto the chord would fold the rim triangles
            # (identity: the same vertex's position on key i's own disk)
            identity_main = method == "identity" and v == "main"
            z_i = loc.interpolate(Fi, p["uv"]) if identity_main else composite[v][i]
            uv_i, jac_i = _to_first_disk(z_i, unrotate[:i])
            X_i = loc.interpolate(Fi, p["Vn"]) @ R.T + tr
            key_uv.append(uv_i)
            key_X.append(X_i)
            if curvature_source == "consistent":
                # (H, λ) of the key's consistent mesh (fig. 7 (d), (e)): the discrete
                # representation of the resampled surface on the shared connectivity
                key_Hn.append(mean_curvature_vector(X_i, cm.F))
                key_H.append(mean_curvature(X_i, cm.F))
                key_lam.append(_safe_conformal_factor(X_i, cm.F, uv_i))
            else:
                key_Hn.append(loc.interpolate(Fi, p["Hn"]) @ R.T)
                key_H.append(loc.interpolate(Fi, p["H"]))
                key_lam.append(loc.interpolate(Fi, p["lam"]) / jac_i)
            if with_colors:
                key_col.append(loc.interpolate(Fi, p["colors"]))
            if v == "main" and all(has_tex):
                key_tex_uv.append(loc.interpolate(Fi, p["tex_uv"]))
        reports = [fold_report(cm.uv, key_uv[i], cm.F) for i in range(1, n_keys)]
        composite_folds[v] = [r.n_folded for r in reports]
        composite_min_jac[v] = [r.min_jacobian_determinant for r in reports]
        if v == "main":
            folded = [(i, n) for i, n in enumerate(composite_folds[v], start=1) if n]
            if folded:
                # the homotopy would sweep through a folded correspondence: refuse
                raise FoldedMapError(
                    "the composite map "
                    + ", ".join(
                        f"to key {i} (mesh {i}) folds {n} of the {cm.F.shape[0]} "
                        "consistent-mesh triangles"
                        for i, n in folded
                    )
                    + f" (registration {reg_method if method != 'identity' else 'identity'}); "
                    "refusing to emit a folded morph: check the landmarks (order, placement) "
                    "and the inputs' disk maps"
                )
        out[f"key_uv__{v}"] = np.stack(key_uv)
        out[f"key_X__{v}"] = np.stack(key_X)
        out[f"key_Hn__{v}"] = np.stack(key_Hn)
        out[f"key_H__{v}"] = np.stack(key_H)
        out[f"key_lam__{v}"] = np.stack(key_lam)
        if key_col:
            out[f"key_colors__{v}"] = np.stack(key_col)
    t_tex = time.perf_counter()
    texture_meta = None
    if key_tex_uv:
        texture_meta = _key_textures(out, prepared, key_tex_uv)
    t_tex = time.perf_counter() - t_tex
    # similarities back to the inputs: S_i = N_i ∘ G_i⁻¹
    Rs, ts, ss = [], [], []
    for i, p in enumerate(prepared):
        G = _similarity(aligned_R[i], aligned_t[i], 1.0)
        Nrm = _similarity(np.eye(3), p["norm_translation"], p["norm_scale"])
        S = Nrm.compose(G.inverse())
        Rs.append(S.rotation)
        ts.append(S.translation)
        ss.append(S.scale)
    out["key_R"] = np.stack(Rs)
    out["key_t"] = np.stack(ts)
    out["key_s"] = np.array(ss)
    out["meta"] = {
        "method": method,
        "registration": reg_method if method != "identity" else "identity",
        "refine": {
            "preset": refine,
            "used": used,
            "rounds": static_refinement,
            "tol": static_tol,
            "guided": static_guided,
        },
        "variants": variants,
        "consistent_mesh": {
            "mode": cm.mode,
            "levels": cm.levels,
            "n_vertices": int(cm.uv.shape[0]),
            "n_faces": int(cm.F.shape[0]),
        },
        "rigid_alignment": rigid_meta,
        "pairs": pair_meta,
        "composite_folded_triangles": composite_folds,
        "composite_min_jacobian": composite_min_jac,
        "texture": texture_meta,
        "appearance": {
            "source": "texture" if key_tex_uv else "vertex_colors" if with_colors else None,
            "inputs_with_vertex_colors": [bool("colors" in p) for p in prepared],
            "note": (
                "vertex colours are used only when every input has them"
                if any("colors" in p for p in prepared) and not with_colors
                else None
            ),
        },
        "seconds": {
            "rigid_alignment": t_rigid - t0,
            "registration": t_reg - t_rigid,
            "resampling": time.perf_counter() - t_reg - t_tex,
            "textures": t_tex,
        },
    }
    return out


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


def _nicp_refinement(
    pa: Arrays,
    pb: Arrays,
    Xa: NDArray[np.float64],
    Xb: NDArray[np.float64],
    loc_a: Any,
    loc_b: Any,
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    reg_d: Any,
    lam_at: Any,
    i: int,
    *,
    icp_iterations: int,
    n_correspondences: int,
    tol: float,
    regularization: float,
) -> tuple[Any, NDArray[np.float64], dict[str, Any]]:
    """Dense DMT correspondences of pair (i − 1, i) by non-rigid ICP (``refine="nicp"``).

    The consistent nodes carried to key i − 1 (``z_prev`` on its disk, a mesh with
    the consistent triangles) are deformed onto key i's surface by
    :func:`geometry.nonrigid_icp.nonrigid_icp`, starting from the landmark DMT
    ``reg_d`` and pinned at the landmarks. Key i is first brought onto key i − 1 by a
    similarity (rigid landmarks and ICP, *with* scale): an expression changes the
    diameter (jawOpen: +5 %), so the diameter-normalised surfaces differ by a scale.
    Up to ``n_correspondences`` farthest-point samples of the nodes that end within
    ``tol`` of the target become extra DMT landmarks (node → closest point's
    position on key i's disk), fitted with Tikhonov ``regularization``; while that
    fit folds (composed steps up to 4 allowed, no smoothing), half as many are tried
    (down to 125), else ``reg_d`` (the landmark DMT) is kept.

    The fit is smooth between its samples; then every node that ended within ``tol``
    of key i's surface is moved from the fit's image to its own closest point's disk
    position, except where that would fold a consistent triangle
    (:func:`geometry.fold_free_offsets.fold_free_offsets` drops those moves with a
    one-ring margin). Measured on the Table 3 curved ICT sequence
    (``benchmarks/bench_nicp_variants.py``, with the earlier 18-iteration ICP schedule):
    DMT/identity at t = 1.3, 1.5 from 1.20, 1.28 (fit only) to 1.19, 1.24; without
    this step the current schedule gives 1.26, 1.39 against 1.18, 1.21 with it.

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
        ``matched``, ``seconds``.
    """
    from geometry.disk_registration import register_disk_landmarks
    from geometry.fold_free_offsets import fold_free_offsets
    from geometry.map_jacobian import map_jacobian_determinants
    from geometry.nonrigid_icp import nonrigid_icp
    from geometry.point_location import PointLocator
    from geometry.rigid_alignment import rigid_landmark_alignment
    from geometry.static_correspondences import farthest_point_samples

    t0 = time.perf_counter()
    P, Q = pa["lm_uv"], pb["lm_uv"]
    la = loc_a.locate(P).interpolate(pa["F"], Xa)
    lb = loc_b.locate(Q).interpolate(pb["F"], Xb)
    G, _ = rigid_landmark_alignment(
        lb, la, with_scale=True, source_surface=Xb, target_surface=Xa, icp_iterations=icp_iterations
    )
    Xt = G.apply(Xb)
    Xs = loc_a.locate(z_prev).interpolate(pa["F"], Xa)
    at = PointLocator(z_prev, cm_F).locate(P)
    # reg_d and the refit below were checked for folds on z_prev: their images are kept
    z0 = reg_d.apply(z_prev) if reg_d.check_image is None else reg_d.check_image
    d0 = loc_b.locate(z0).interpolate(pb["F"], Xt) - Xs
    inner = (np.linalg.norm(z_prev, axis=1) < 0.95).astype(np.float64)
    res = nonrigid_icp(
        Xs,
        cm_F,
        Xt,
        pb["F"],
        at.triangle,
        at.barycentric,
        G.apply(lb),
        initial_displacement=d0,
        weights=inner,
    )
    q_all = np.einsum("kj,kjd->kd", res.barycentric, pb["uv"][pb["F"][res.triangle]])
    close = res.matched & (inner > 0) & (res.distance <= tol)
    cand = np.flatnonzero(close)
    ids = farthest_point_samples(Xs, n_correspondences, candidates=cand)
    tried: list[int] = []
    out = reg_d
    k = ids.size
    while k >= 125:
        tried.append(int(k))
        P2 = np.vstack([P, z_prev[ids[:k]]])
        Q2 = np.vstack([Q, q_all[ids[:k]]])
        refined = register_disk_landmarks(
            P2,
            Q2,
            z_prev,
            cm_F,
            method="dmt",
            kernel_scale=lam_at(i, Q2) / lam_at(i - 1, P2),
            # Tikhonov ε: the exact interpolant through ~10³ nodes folds at every count
            # tried (measured on the ICT Table 3 pairs); with ε = 1e-8 the landmarks are
            # met to E_D ~1e-5 (1.8e-3 on ICT neutral→jawOpen), not exactly
            regularization=regularization,
            on_fold="fallback",
            max_steps=4,
            fold_regularizations=(),  # a smoothed fit is rejected anyway: do not try one
        )
        if refined.fallback in (None, "stepwise"):
            out = refined
            break
        k //= 2
    used = tried[-1] if out is not reg_d else 0
    # the thin-plate fit through the samples is smooth between them; every node that
    # ended on key i's surface takes its own closest point instead, except where that
    # would fold a consistent triangle
    z_fit = out.apply(z_prev) if out.check_image is None else out.check_image
    z_next, n_dense, n_dropped = z_fit, 0, 0
    # a fit that folds is refused by the caller's composite check; nothing to add to it
    if np.all(map_jacobian_determinants(z_prev, z_fit, cm_F) > 0):
        offsets = np.where(close[:, None], q_all - z_fit, 0.0)
        dense = fold_free_offsets(z_prev, z_fit, offsets, cm_F)
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
            "seconds": time.perf_counter() - t0,
        },
    )


def _key_textures(
    out: Arrays, prepared: Sequence[Arrays], key_tex_uv: Sequence[NDArray[np.float64]]
) -> dict[str, Any]:
    """Render every key's texture on the consistent mesh's atlas layout (into ``out``).

    The layout is the first input's texture coordinates at the consistent
    nodes (its own UVs in ``consistent="source"`` mode); the atlas has the
    first texture's size, at most :data:`MAX_TEXTURE_SIZE` texels a side. The
    reported ``coverage`` is the smallest fraction of atlas texels covered by any key.
    """
    from geometry.consistent_mesh import resample_texture

    layout = key_tex_uv[0]
    h, w = prepared[0]["texture"].shape[:2]
    f = min(1.0, MAX_TEXTURE_SIZE / max(h, w))
    shape = (max(1, round(h * f)), max(1, round(w * f)))
    atlases, coverage = [], 1.0
    for i, p in enumerate(prepared):
        img = np.asarray(p["texture"], dtype=np.float64) / 255.0
        tex, covered = resample_texture(layout, out["cm_F"], key_tex_uv[i], img, shape)
        atlases.append(np.clip(np.rint(tex * 255.0), 0, 255).astype(np.uint8))
        coverage = min(coverage, float(covered.mean()))  # the least covered key's
    out["cm_tex_uv"] = layout
    out["key_tex_uv"] = np.stack(key_tex_uv)
    out["key_textures"] = np.stack(atlases)
    return {"size": [int(shape[0]), int(shape[1])], "layout": "mesh 0's UVs", "coverage": coverage}


def _to_first_disk(
    uv: NDArray[np.float64], inverse_mts: Sequence[Any]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Carry points of key i's disk to key 0's Möbius frame: M_1⁻¹ ∘ … ∘ M_i⁻¹.

    Parameters
    ----------
    uv : (p, 2) float64
        Points on key i's disk.
    inverse_mts : sequence of MobiusTransform
        The inverse optimal Möbius transformations of pairs 1 … i, in order.

    Returns
    -------
    uv : (p, 2) float64
    jacobian : (p,) float64
        |d(uv')/d(uv)|², the factor by which disk areas grow (λ = 3D area /
        disk area is divided by it).
    """
    z = np.asarray(uv, dtype=np.float64)
    jac = np.ones(z.shape[0])
    for M in reversed(list(inverse_mts)):
        jac = jac * M.jacobian_determinant(z)
        z = M.apply(z)
    return z, jac


def _safe_conformal_factor(
    X: NDArray[np.float64], F: NDArray[np.int64], uv: NDArray[np.float64]
) -> NDArray[np.float64]:
    """λ of a consistent mesh; one-rings collapsed on the disk get their neighbours' value."""
    from geometry import vertex_areas

    A3 = vertex_areas(X, F)
    Auv = vertex_areas(uv, F)
    ok = Auv > 0
    if not ok.all():
        raise ValueError(f"{int((~ok).sum())} consistent-mesh one-rings have zero disk area")
    return np.asarray(A3 / Auv)


def _surface_error(p: Arrays, locator: Any, mapped: NDArray[np.float64]) -> float:
    """E of eq. (3) on the normalised target surface."""
    from geometry.registration_error import surface_registration_error

    return surface_registration_error(
        mapped, p["uv"], p["Vn"], p["F"], p["lm_points"], locator=locator
    )


#: what each DMT fallback of :func:`geometry.disk_registration.register_disk_landmarks` means
DMT_FALLBACKS = {
    "stepwise": "DMT split into composed thin-plate steps to avoid a fold (still exact at the "
    "landmarks)",
    "regularized": "DMT would fold: smoothed by Tikhonov regularisation, no longer exact at "
    "the landmarks",
    "mt": "DMT folded at every strength tried: the MT map is used for this pair",
}


def bijectivity_summary(
    inputs: Sequence[dict[str, Any]], registration: dict[str, Any]
) -> dict[str, Any]:
    """One place that says whether every map of the morph is a bijection, and what fell back.

    Parameters
    ----------
    inputs : sequence of dict
        Stage-1 ``meta`` of every input (``disk_map`` diagnostics).
    registration : dict
        Stage-2 ``meta``.

    Returns
    -------
    dict
        ``folded_triangles`` (total over the disk maps and the homotopy's
        composite maps: 0 for anything the pipeline emits, which refuses
        folded maps), ``disk_map_folded``, ``disk_map_folded_before_repair``,
        ``composite_folded``, ``min_jacobian`` (smallest Jacobian determinant
        of the composite maps, > 0), and ``fallbacks``: one entry per pair
        whose DMT fell back (``pair``, ``fallback``, ``message``; empty for
        MT and identity, which use no DMT).
    """
    disk = [int(m["disk_map"]["flipped"]) for m in inputs]
    before = [int(m["disk_map"]["flipped_before_repair"]) for m in inputs]
    comp = [int(n) for n in registration["composite_folded_triangles"]["main"]]
    jac = [float(j) for j in registration.get("composite_min_jacobian", {}).get("main", [])]
    fallbacks = []
    if registration["registration"] == "dmt":
        for pm in registration["pairs"]:
            fb = pm.get("dmt_fallback")
            if fb is not None:
                fallbacks.append(
                    {"pair": pm["pair"], "fallback": fb, "message": DMT_FALLBACKS.get(fb, fb)}
                )
    return {
        "folded_triangles": int(sum(disk) + sum(comp)),
        "disk_map_folded": disk,
        "disk_map_folded_before_repair": before,
        "composite_folded": comp,
        "min_jacobian": min(jac) if jac else None,
        "fallbacks": fallbacks,
    }


# --------------------------------------------------------------------------- stage 3


def frame_times_for(times: NDArray[np.float64], frames: int) -> NDArray[np.float64]:
    """``frames`` times evenly spaced from t0 to tN inclusive."""
    if frames < 2:
        raise ValueError(f"--frames must be ≥ 2, got {frames}")
    return np.linspace(float(times[0]), float(times[-1]), int(frames))


def _check_frame_times(frame_times: Sequence[float]) -> NDArray[np.float64]:
    """Explicit frame times as an array: at least one, finite, strictly increasing."""
    ft = np.asarray(frame_times, dtype=np.float64).reshape(-1)
    if ft.size < 1:
        raise ValueError("--frame-times needs at least one time")
    if not np.all(np.isfinite(ft)) or np.any(np.diff(ft) <= 0):
        raise ValueError(f"--frame-times must be finite and strictly increasing, got {ft.tolist()}")
    return ft


def _keys(reg: Arrays, v: str, curvature: str) -> dict[str, Any]:
    d = {
        "key_uv": reg[f"key_uv__{v}"],
        "key_lam": reg[f"key_lam__{v}"],
        "key_curvature": reg[f"key_Hn__{v}"] if curvature != "scalar" else reg[f"key_H__{v}"],
        "key_boundary": reg[f"key_X__{v}"][:, reg["cm_b"]],
    }
    if curvature in ("metric", "screened"):
        from geometry.intrinsic_laplacian import edge_lengths

        X = reg[f"key_X__{v}"]
        d["key_lengths"] = np.stack([edge_lengths(x, reg["cm_F"]) for x in X])
    if curvature == "screened":
        from geometry.morph_frames import SCREEN_WEIGHT

        d["key_positions"] = reg[f"key_X__{v}"]
        d["screen_weight"] = SCREEN_WEIGHT
    return d


def _transforms(reg: Arrays) -> list[Any]:
    return [
        _similarity(reg["key_R"][i], reg["key_t"][i], reg["key_s"][i])
        for i in range(reg["key_R"].shape[0])
    ]


def _placed_keys(reg: Arrays, v: str) -> NDArray[np.float64]:
    T = _transforms(reg)
    X = reg[f"key_X__{v}"]
    return np.stack([T[i].apply(X[i]) for i in range(X.shape[0])])


def morph_variant_frames(
    reg: Arrays,
    times: NDArray[np.float64],
    frame_times: NDArray[np.float64],
    *,
    variant: str,
    curvature: str,
    linear: bool = False,
) -> NDArray[np.float64]:
    """Frames in input coordinates, (T, n, 3), for one registration variant.

    ``linear=True`` gives the linear-vertex-interpolation baseline of the
    variant's keys (in input coordinates, so that it is exact on a path
    linear in vertex space).
    """
    from geometry.morph_frames import linear_vertex_frames, morph_frames

    if linear:
        return linear_vertex_frames(times, _placed_keys(reg, variant), frame_times)
    fr = morph_frames(
        reg["cm_F"],
        reg["cm_b"],
        times,
        frame_times=frame_times,
        transforms=_transforms(reg),
        **_keys(reg, variant, curvature),
    )
    return np.stack([fr.placed(k) for k in range(frame_times.size)])


def compute_frames(
    reg: Arrays,
    prepared_meshes: Sequence[tuple[NDArray[np.float64], NDArray[np.int64]]],
    times: NDArray[np.float64],
    frame_times: NDArray[np.float64],
    *,
    curvature: str = DEFAULT_CURVATURE,
    truths: Sequence[tuple[float, NDArray[np.float64], NDArray[np.int64]]] = (),
    key_metrics: bool = True,
) -> Arrays:
    """Stage 3: the homotopy frames and their metrics.

    Parameters
    ----------
    reg : stage-2 dict
    prepared_meshes : sequence of (V, F)
        The input meshes (input coordinates), for the key-frame metrics.
    times : (N + 1,) float64
        Key times.
    frame_times : (T,) float64
    curvature : {"metric", "vector", "scalar", "screened"}
        Homotopy of the curvature (see :mod:`geometry.morph_frames`):
        ``screened`` (default) — ``metric`` screened towards the cubic spline of
        the key positions (:data:`geometry.morph_frames.SCREEN_WEIGHT`);
        ``metric`` — mean-curvature vector with the Laplacian of the
        interpolated metric; ``vector`` — mean-curvature vector with the disk
        Laplacian; ``scalar`` — the paper's scalar H with Algorithm 1. The
        default was chosen by measurement (``benchmarks/bench_face_tables.py``,
        DMT keys of different connectivity, relative L2 distance to the true
        in-between ICT surfaces at t = 0.3, 0.5, 1.3, 1.5): screened
        1.1e-3, 1.2e-3, 0.7e-3, 0.9e-3 against metric 3.4e-3, 4.2e-3, 3.9e-3,
        4.7e-3 on the curved path; 2.8e-3–3.0e-3 against 4.3e-3–5.9e-3 on a
        path with sinusoidal blend weights; lower on the linear path too.
    truths : sequence of (t, V_true, F_true)
        Known surfaces at times t, compared with every method's frame.
    key_metrics : bool
        Reconstruct the key frames and measure their distance to the inputs.

    Returns
    -------
    dict
        ``frames_V (T, n, 3)`` in input coordinates, ``frames_aligned (T, n, 3)``,
        ``frame_R (T, 3, 3)``, ``frame_t (T, 3)``, ``frame_s (T,)``,
        ``frame_times``, optional ``frames_colors (T, n, c)``, optional
        ``frame_texture_weights (T, N + 1)`` (frame k's texture is
        ``Σ_i w[k, i] key_textures[i]``), and ``meta``.
    """
    from geometry.morph_frames import linear_vertex_frames, morph_frames
    from geometry.spline_homotopy import SplineHomotopy
    from geometry.surface_distance import surface_to_surface_error

    if curvature not in CURVATURE_HOMOTOPIES:
        raise ValueError(
            f"curvature must be one of {', '.join(CURVATURE_HOMOTOPIES)}, got {curvature!r}"
        )
    method = reg["meta"]["method"]
    times = np.asarray(times, dtype=np.float64)
    t0 = time.perf_counter()
    out: Arrays = {"frame_times": frame_times}
    F = reg["cm_F"]
    if method == "linear":
        Vf = linear_vertex_frames(times, _placed_keys(reg, "main"), frame_times)
        out["frames_V"] = Vf
        out["frames_aligned"] = Vf
        out["frame_R"] = np.broadcast_to(np.eye(3), (frame_times.size, 3, 3)).copy()
        out["frame_t"] = np.zeros((frame_times.size, 3))
        out["frame_s"] = np.ones(frame_times.size)
        iterations: list[int] = []
    else:
        fr = morph_frames(
            F,
            reg["cm_b"],
            times,
            frame_times=frame_times,
            transforms=_transforms(reg),
            **_keys(reg, "main", curvature),
        )
        out["frames_aligned"] = fr.V
        out["frames_V"] = np.stack([fr.placed(k) for k in range(frame_times.size)])
        out["frame_R"] = np.stack([T.rotation for T in fr.transforms])
        out["frame_t"] = np.stack([T.translation for T in fr.transforms])
        out["frame_s"] = np.array([T.scale for T in fr.transforms])
        iterations = fr.iterations
    if "key_colors__main" in reg:
        col = SplineHomotopy(times, reg["key_colors__main"])(frame_times)
        out["frames_colors"] = np.clip(col, 0.0, 1.0)
    if "key_textures" in reg:
        # the texel colours follow the same cubic spline in t; the spline is linear in
        # its data, so frame k's texture is Σ_i w[k, i] · key texture i with the weights
        # of the spline through the unit vectors (the textures are blended at export)
        K = reg["key_textures"].shape[0]
        out["frame_texture_weights"] = SplineHomotopy(times, np.eye(K))(frame_times)
    t_frames = time.perf_counter()

    variants = {"main": method}
    if "key_uv__mt" in reg:
        variants["mt"] = "mt"
    meta: dict[str, Any] = {
        "method": method,
        "curvature_homotopy": curvature if method != "linear" else None,
        "n_frames": int(frame_times.size),
        "reconstruction_iterations": iterations,
        "linear_baseline_note": (
            "linear vertex interpolation reproduces every key exactly and is exact on any path "
            "that is linear in vertex space between keys (e.g. a linear blend-shape path); its "
            "errors below are 0 at the keys by construction, not by merit"
        ),
    }
    if key_metrics:
        km: dict[str, Any] = {}
        for v, name in variants.items():
            if name == "linear":
                continue
            Vk = morph_variant_frames(reg, times, times, variant=v, curvature=curvature)
            km[name] = [
                surface_to_surface_error(Vk[i], F, *prepared_meshes[i])["L2"]
                for i in range(times.size)
            ]
        km["linear"] = [
            surface_to_surface_error(P, F, *prepared_meshes[i])["L2"]
            for i, P in enumerate(_placed_keys(reg, "main"))
        ]
        meta["key_frame_L2_to_inputs"] = km
    if truths:
        tt = np.array([t for t, _, _ in truths], dtype=np.float64)
        res: dict[str, Any] = {"times": tt.tolist()}
        for v, name in variants.items():
            if name == "linear":
                continue
            Vt = morph_variant_frames(reg, times, tt, variant=v, curvature=curvature)
            res[name] = [
                surface_to_surface_error(Vt[k], F, Vtr, Ftr)
                for k, (_, Vtr, Ftr) in enumerate(truths)
            ]
        Vl = linear_vertex_frames(times, _placed_keys(reg, "main"), tt)
        res["linear"] = [
            surface_to_surface_error(Vl[k], F, Vtr, Ftr) for k, (_, Vtr, Ftr) in enumerate(truths)
        ]
        meta["truth_errors"] = res
    meta["seconds"] = {"frames": t_frames - t0, "metrics": time.perf_counter() - t_frames}
    out["meta"] = meta
    return out


# --------------------------------------------------------------------------- stage 4


def export_outputs(
    reg: Arrays,
    frames: Arrays,
    outdir: str | Path,
    *,
    per_frame: bool = False,
    sparse: bool = False,
    normals: bool = False,
) -> dict[str, Any]:
    """Stage 4: write ``animation.glb`` (and ``frames/NNN.glb`` with ``per_frame``).

    The base mesh is frame 0 in the aligned frame; each frame is a morph
    target; the interpolated similarity rides on the node's TRS channels.

    Parameters
    ----------
    reg : stage-2 dict
    frames : stage-3 dict
    outdir : path
        Output folder (created).
    per_frame : bool
        Also write ``frames/NNN.glb`` (frame k with its rigid motion applied).
    sparse : bool
        Sparse morph targets.
    normals : bool
        Also write base vertex normals and a ``NORMAL`` delta per morph target
        (and normals in the per-frame files). Off by default: the glTF spec
        guarantees viewers only 8 morphed attributes, and with normals each
        active target uses two (at most two targets are active at once here,
        so 4 of the 8 with normals, 6 with colour targets too).

    Returns
    -------
    dict
        File name → size in bytes.

    Notes
    -----
    Appearance. Vertex colours (when every input has them) ride on
    ``COLOR_0`` with one colour delta per morph target, so they cross-fade
    with the shape (three.js and Babylon morph colours; Blender imports
    positions only). Textures (when every input has UVs and an image): each
    key's texture is rendered on one atlas layout over the consistent mesh
    (the first input's UVs, ``TEXCOORD_0``); frame k's texture is the spline
    blend of the key textures. Core glTF cannot animate a texture, so
    ``animation.glb`` carries frame 0's texture (static) and no ``COLOR_0``
    (which would multiply it); every ``frames/NNN.glb`` carries its own
    blended texture (the cross-fade), and ``textures/key_NNN.png`` are the
    key textures on the shared layout, for viewers that blend textures
    themselves.
    """
    from geometry.rotation_interpolation import rotation_to_quaternion_xyzw
    from pipelines.export_gltf import write_frame_glb, write_morph_glb

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    F = reg["cm_F"]
    Va = frames["frames_aligned"]
    te = frames["frame_times"]
    anim_t = te - te[0]
    colors = frames.get("frames_colors")
    files: dict[str, Any] = {}
    uv = None
    textures = reg.get("key_textures")
    weights = frames.get("frame_texture_weights")
    if textures is not None and weights is not None:
        colors = None
        uv = np.c_[reg["cm_tex_uv"][:, 0], 1.0 - reg["cm_tex_uv"][:, 1]]  # glTF: origin top left
        (out / "textures").mkdir(exist_ok=True)
        for i in range(textures.shape[0]):
            name = f"textures/key_{i:03d}.png"
            (out / name).write_bytes(_png(textures[i]))
            files[name] = (out / name).stat().st_size

    def frame_png(k: int) -> bytes | None:
        if textures is None or weights is None:
            return None
        blend = np.einsum("i,ihwc->hwc", weights[k], textures.astype(np.float64))
        return _png(np.clip(np.rint(blend), 0, 255).astype(np.uint8))

    q = rotation_to_quaternion_xyzw(frames["frame_R"])
    s = np.repeat(frames["frame_s"][:, None], 3, axis=1)
    info = write_morph_glb(
        out / "animation.glb",
        Va[0],
        F,
        Va,
        anim_t,
        normals=normals,
        colors=colors,
        uv=uv,
        texture_png=frame_png(0),
        rigid=(frames["frame_t"], q, s),
        sparse=sparse,
        name="face_morph",
        target_names=[f"t={t:.4g}" for t in te],
    )
    files["animation.glb"] = int(info.get("bytes", 0))
    if per_frame:
        (out / "frames").mkdir(exist_ok=True)
        for k in range(te.size):
            p = out / "frames" / f"{k:03d}.glb"
            write_frame_glb(
                p,
                frames["frames_V"][k],
                F,
                normals=normals,
                colors=None if colors is None else colors[k],
                uv=uv,
                texture_png=frame_png(k),
            )
            files[f"frames/{k:03d}.glb"] = p.stat().st_size
    return files


def _png(image: NDArray[np.uint8]) -> bytes:
    """PNG bytes of an (h, w, 3) uint8 image."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image), "RGB").save(buf, "PNG")
    return buf.getvalue()


# --------------------------------------------------------------------------- driver


#: longest side of the texture atlas resampled onto the consistent mesh (texels)
MAX_TEXTURE_SIZE = 2048


def _load_trimesh(mesh_path: str | Path, file_type: str | None) -> Any:
    import trimesh

    path = Path(mesh_path)
    ftype = (file_type or path.suffix.lstrip(".")).lower()
    with open(path, "rb") as fh:
        return trimesh.load(fh, file_type=ftype, process=False, maintain_order=True, force="mesh")


def read_texture(
    mesh_path: str | Path, image_path: str | Path, n_vertices: int, *, file_type: str | None = None
) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Per-vertex texture coordinates of a mesh file and its texture image.

    Parameters
    ----------
    mesh_path : path
        The mesh (OBJ with one ``vt`` per vertex, or any trimesh-readable
        file with per-vertex UVs).
    image_path : path
        The texture image (any format PIL reads).
    n_vertices : int
        Vertex count of the mesh as read by :func:`pipelines.mesh_io.read_mesh`.
    file_type : str, optional
        Mesh file type when the path has no telling extension.

    Returns
    -------
    uv : (n, 2) float64
        Texture coordinates, origin at the image's bottom-left corner (OBJ
        convention).
    image : (h, w, 3) uint8
        RGB texels, row 0 at the top.

    Raises
    ------
    ValueError
        The mesh has no per-vertex UVs (or UVs that split vertices at seams).
    OSError
        The image cannot be read.
    """
    from PIL import Image

    m = _load_trimesh(mesh_path, file_type)
    uv = getattr(getattr(m, "visual", None), "uv", None)
    if uv is None or len(uv) != n_vertices:
        raise ValueError(
            f"{mesh_path}: --texture needs one texture coordinate per vertex (vt), "
            f"found {0 if uv is None else len(uv)} for {n_vertices} vertices"
        )
    uv = np.asarray(uv, dtype=np.float64)
    if not np.all(np.isfinite(uv)):
        raise ValueError(f"{mesh_path}: non-finite texture coordinates")
    with Image.open(image_path) as im:
        img = np.asarray(im.convert("RGB"), dtype=np.uint8)
    return uv, img


def read_vertex_colors(
    mesh_path: str | Path, n_vertices: int, *, file_type: str | None = None
) -> NDArray[np.float64] | None:
    """Per-vertex RGB colours stored in a mesh file (PLY colour properties, OBJ ``v x y z r g b``).

    Parameters
    ----------
    mesh_path : path
    n_vertices : int
        Vertex count of the mesh as read by :func:`pipelines.mesh_io.read_mesh`.
    file_type : str, optional
        Mesh file type when the path has no telling extension.

    Returns
    -------
    (n, 3) float64 in [0, 1], or None
        None when the file has no vertex colours (or not one per vertex).
    """
    path = Path(mesh_path)
    ftype = (file_type or path.suffix.lstrip(".")).lower()
    if ftype in ("obj", "ply"):
        # cheap look first: most meshes carry no colours, and parsing twice costs time
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
        if ftype == "ply":
            header = head.split(b"end_header")[0]
            if b" red" not in header and b" r\n" not in header:
                return None
        else:
            vline = next((ln for ln in head.splitlines() if ln.startswith(b"v ")), b"")
            if len(vline.split()) < 7:
                return None
    m = _load_trimesh(mesh_path, file_type)
    vis = getattr(m, "visual", None)
    if vis is None or getattr(vis, "kind", None) != "vertex":
        return None
    c = np.asarray(vis.vertex_colors)
    if c.ndim != 2 or c.shape[0] != n_vertices or c.shape[1] < 3:
        return None
    return np.asarray(c[:, :3], dtype=np.float64) / 255.0


def _remove_ears(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    entries: list[Any],
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
    mesh_index: int,
) -> tuple[Any, Any, list[Any], Any, Any]:
    """Remove boundary ears and translate vertex-index landmarks."""
    from geometry import remove_boundary_ears
    from pipelines.landmarks_io import LandmarkIndexError

    V2, F2, kept = remove_boundary_ears(V, F)
    new: list[Any] = []
    for j, e in enumerate(entries):
        if isinstance(e, int | float) and not isinstance(e, bool):
            k = int(np.searchsorted(kept, int(e)))
            if k >= kept.size or kept[k] != int(e):
                raise LandmarkIndexError(
                    f"mesh {mesh_index}, landmark {j}: vertex {int(e)} is a boundary ear removed "
                    "by --remove-ears"
                )
            new.append(k)
        else:
            new.append(e)
    return (
        V2,
        F2,
        new,
        None if tex_uv is None else tex_uv[kept],
        None if colors is None else colors[kept],
    )


def _fill_holes(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
) -> tuple[Any, Any, Any, Any]:
    """Fill holes with fans; a new centre's UV and colour average its loop's."""
    from geometry import fill_holes

    V2, F2 = fill_holes(V, F)
    n, m = V.shape[0], F.shape[0]
    fans = F2[m:]  # (loop vertex j+1, j, centre c): each loop vertex once per centre

    def extend(a: NDArray[np.float64] | None) -> NDArray[np.float64] | None:
        if a is None or V2.shape[0] == n:
            return a
        sums = np.zeros((V2.shape[0] - n, a.shape[1]))
        np.add.at(sums, fans[:, 2] - n, a[fans[:, 1]])
        counts = np.bincount(fans[:, 2] - n, minlength=V2.shape[0] - n)
        return np.vstack([a, sums / counts[:, None]])

    return V2, F2, extend(tex_uv), extend(colors)


def repair_key_mesh(
    V: NDArray[np.float64],
    F: NDArray[np.int64],
    entries: list[Any],
    tex_uv: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
    mesh_index: int,
    *,
    fill_holes: bool,
    remove_ears: bool,
) -> tuple[Any, Any, list[Any], Any, Any]:
    """The requested repairs of one key mesh (``--fill-holes``, then ``--remove-ears``).

    Holes are filled with fans (input ids kept, centres appended, their UVs
    and colours averaged over the loop); ears are removed and vertex-index
    landmarks translated (a landmark on a removed ear is an error). Returns
    ``(V, F, entries, tex_uv, colors)``, the inputs themselves without repairs.
    """
    if fill_holes:
        V, F, tex_uv, colors = _fill_holes(V, F, tex_uv, colors)
    if remove_ears:
        V, F, entries, tex_uv, colors = _remove_ears(V, F, entries, tex_uv, colors, mesh_index)
    return V, F, entries, tex_uv, colors


def run_face_morph(
    mesh_paths: Sequence[str | Path],
    landmarks_path: str | Path,
    outdir: str | Path,
    *,
    times: Sequence[float] | None = None,
    frames: int = 30,
    frame_times: Sequence[float] | None = None,
    method: str = "dmt",
    textures: Sequence[str | Path] | None = None,
    per_frame: bool = False,
    normals: bool = False,
    progress: ProgressFn | None = None,
    curvature: str = DEFAULT_CURVATURE,
    consistent: str = "source",
    refine: str = "auto",
    remove_ears: bool = False,
    fill_holes: bool = False,
    truths: Sequence[tuple[float, str | Path]] = (),
    key_metrics: bool = True,
    write_glb: bool = True,
) -> dict[str, Any]:
    """Morph two or more face meshes with landmarks; write the GLB(s) and ``metrics.json``.

    Parameters
    ----------
    mesh_paths : sequence of paths
        Key meshes M0 … MN (N ≥ 1), disks, any connectivity each.
    landmarks_path : path
        Landmark JSON (see :mod:`pipelines.landmarks_io`).
    outdir : path
        Output folder (created).
    times : sequence of float, optional
        Key times, strictly increasing; default 0 … N.
    frames : int
        Frames evenly spaced from t0 to tN inclusive.
    frame_times : sequence of float, optional
        Explicit frame times instead of ``frames``, strictly increasing; they
        may lie outside [t0, tN], where the homotopy extrapolates (the end
        cubic pieces are continued, Table 4 of the paper). The animation's
        clock starts at the first one.
    method : {"dmt", "mt", "identity", "linear"}
    textures : sequence of paths, optional
        One image per mesh (meshes must carry per-vertex UVs).
    per_frame : bool
        Also write ``frames/NNN.glb``.
    normals : bool
        Write vertex normals and per-target normal deltas (see
        :func:`export_outputs`).
    progress : callable(fraction, stage), optional
    curvature : {"screened", "metric", "vector", "scalar"}
        Curvature homotopy; the default ``screened`` was chosen by measurement
        (``benchmarks/bench_face_tables.py``), see :func:`compute_frames`.
    consistent : {"source", "landmarks"}
        Consistent mesh.
    refine : {"auto", "nicp", "guided", "static", "none"}
        Extra DMT correspondences (see :func:`register_meshes`; ``none`` is
        the paper's landmark-only DMT).
    remove_ears : bool
        Remove boundary "ear" vertices (in a single triangle) from every input
        first (:func:`geometry.remove_boundary_ears`); landmark vertex indices
        are translated, and a landmark on a removed vertex is an error.
    fill_holes : bool
        Close every boundary loop but the outer one with a fan to its centroid
        first (:func:`geometry.fill_holes`; before ``remove_ears``): the input
        vertices keep their ids (landmarks still apply), the hole centres are
        appended and carry the mean UV and colour of their loop.
    truths : sequence of (t, mesh path)
        Known surfaces for error metrics.
    key_metrics : bool
        Measure reconstructed key frames against the inputs.
    write_glb : bool
        Write the GLB files (off for benchmarks).

    Returns
    -------
    dict
        The metrics also written to ``metrics.json``.
    """
    from geometry.threads import map_in_threads
    from pipelines.landmarks_io import read_landmark_file
    from pipelines.mesh_io import read_mesh

    def report(f: float, stage: str) -> None:
        if progress is not None:
            progress(f, stage)

    t_start = time.perf_counter()
    if method not in METHODS:
        raise ValueError(f"--method must be one of {', '.join(METHODS)}, got {method!r}")
    paths = [Path(p) for p in mesh_paths]
    if len(paths) < 2:
        raise ValueError(f"need at least 2 meshes, got {len(paths)}")
    key_times = (
        np.arange(len(paths), dtype=np.float64)
        if times is None
        else np.asarray(times, dtype=np.float64)
    )
    if key_times.shape != (len(paths),):
        raise ValueError(f"--times needs {len(paths)} values (one per mesh), got {key_times.size}")
    if np.any(np.diff(key_times) <= 0) or not np.all(np.isfinite(key_times)):
        raise ValueError(f"--times must be strictly increasing, got {key_times.tolist()}")
    ft = (
        frame_times_for(key_times, frames)
        if frame_times is None
        else _check_frame_times(frame_times)
    )
    if textures is not None and len(textures) not in (0, len(paths)):
        raise ValueError(f"--texture needs one image per mesh ({len(paths)}), got {len(textures)}")
    entries = read_landmark_file(landmarks_path, len(paths))
    seconds: dict[str, float] = {}

    t = time.perf_counter()

    def prepare_key(i: int) -> tuple[Arrays, tuple[NDArray[np.float64], NDArray[np.int64]]]:
        p = paths[i]
        V, F = read_mesh(p)
        tex_uv = image = None
        colors = None if textures else read_vertex_colors(p, V.shape[0])
        if textures:
            tex_uv, image = read_texture(p, textures[i], V.shape[0])
        V, F, entry, tex_uv, colors = repair_key_mesh(
            V, F, entries[i], tex_uv, colors, i, fill_holes=fill_holes, remove_ears=remove_ears
        )
        key = prepare_mesh(V, F, entry, mesh_index=i, tex_uv=tex_uv, colors=colors, texture=image)
        return key, (V, F)

    # the keys are independent: side by side on threads (geometry.threads), the first
    # failing key (in input order) raising
    keys = map_in_threads(prepare_key, range(len(paths)))
    prepared = [k for k, _ in keys]
    meshes = [m for _, m in keys]
    report(0.4, "maps")
    seconds["maps"] = time.perf_counter() - t

    t = time.perf_counter()
    reg = register_meshes(
        prepared,
        method=method,
        consistent=consistent,
        refine=refine,
        baselines=key_metrics or bool(truths),
    )
    seconds["registration"] = time.perf_counter() - t
    report(0.55, "registration")

    t = time.perf_counter()
    truth_meshes = [(float(tt), *read_mesh(pp)) for tt, pp in truths]
    fr = compute_frames(
        reg,
        meshes,
        key_times,
        ft,
        curvature=curvature,
        truths=truth_meshes,
        key_metrics=key_metrics,
    )
    seconds["frames"] = fr["meta"]["seconds"]["frames"]
    seconds["frame_metrics"] = fr["meta"]["seconds"]["metrics"]
    report(0.85, "frames")

    t = time.perf_counter()
    files: dict[str, Any] = {}
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    if write_glb:
        files = export_outputs(reg, fr, out, per_frame=per_frame, normals=normals)
    seconds["export"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t_start
    metrics = {
        "inputs": [pp["meta"] for pp in prepared],
        "bijectivity": bijectivity_summary([pp["meta"] for pp in prepared], reg["meta"]),
        "key_times": key_times.tolist(),
        "frame_times": ft.tolist(),
        "registration": reg["meta"],
        "frames": fr["meta"],
        "files": files,
        "seconds": seconds,
    }
    metrics = jsonable(metrics)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    report(1.0, "done")
    return metrics
