"""Measures of a face morph: key frames against the inputs, frames against known
in-between surfaces (truths), the bijectivity of every map, the ``metrics.json`` document."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.homotopy import morph_variant_frames, placed_keys
from conformorph.pipelines.face_morph.options import Arrays

#: what each DMT fallback of :func:`conformorph.geometry.disk_registration.register_disk_landmarks` means
DMT_FALLBACKS = {
    "stepwise": "DMT split into composed thin-plate steps to avoid a fold (still exact at the "
    "landmarks)",
    "regularized": "DMT would fold: smoothed by Tikhonov regularisation, no longer exact at "
    "the landmarks",
    "mt": "DMT folded at every strength tried: the MT map is used for this pair",
}

#: surfaces above this many vertices get their key-frame metrics on this many
#: area-weighted samples (:func:`conformorph.geometry.sampled_surface_l2`)
KEY_METRIC_SAMPLES = 8192

Mesh = tuple[NDArray[np.float64], NDArray[np.int64]]
Truth = tuple[float, NDArray[np.float64], NDArray[np.int64]]


def registration_variants(reg: Arrays) -> dict[str, str]:
    """Variant → the method it measures (``main`` → the homotopy's, ``mt`` → ``"mt"``)."""
    variants = {"main": str(reg["meta"]["method"])}
    if "key_uv__mt" in reg:
        variants["mt"] = "mt"
    return variants


def delivered_key_frames(
    frames: Arrays | None, times: NDArray[np.float64]
) -> NDArray[np.float64] | None:
    """The homotopy's frames at the key times, (N + 1, n, 3), from stage 3, or None.

    Parameters
    ----------
    frames : stage-3 dict or None
        Its ``frame_times`` (T,) and ``frames_V`` (T, n, 3) (input coordinates).
    times : (N + 1,) float64
        Key times.

    Returns
    -------
    (N + 1, n, 3) float64 or None
        None when some key time is not a frame time (or no frames are given).

    Notes
    -----
    :func:`conformorph.geometry.morph_frames.morph_frames` factorises every frame at
    a key time, so such a frame is, to the bit, what a solve at the key times alone
    gives: the key-frame metrics measure the frames written to the GLB without
    solving them again.
    """
    if frames is None or "frames_V" not in frames or "frame_times" not in frames:
        return None
    ft = np.asarray(frames["frame_times"], dtype=np.float64)
    idx = [np.flatnonzero(ft == t) for t in np.asarray(times, dtype=np.float64)]
    if any(i.size == 0 for i in idx):
        return None
    return np.asarray(frames["frames_V"], dtype=np.float64)[[int(i[0]) for i in idx]]


def key_frame_metrics(
    reg: Arrays,
    meshes: Sequence[Mesh],
    times: NDArray[np.float64],
    curvature: str,
    *,
    frames: Arrays | None = None,
    bounds: dict[str, list[float]] | None = None,
) -> dict[str, list[float]]:
    """Relative L2 distance of every method's reconstructed key frames to the inputs.

    Measured by :func:`conformorph.geometry.sampled_surface_l2`: exactly on meshes of at
    most :data:`KEY_METRIC_SAMPLES` vertices, above that on that many area-weighted
    samples per surface (a 48k-vertex pair: 6x faster, measured 0.05 bounds from the
    exact figure), with three standard errors as the bound.

    Parameters
    ----------
    reg : stage-2 dict
    meshes : sequence of (V (n_i, 3), F (m_i, 3))
        The inputs in input coordinates.
    times : (N + 1,) float64
        Key times.
    curvature : str
        Curvature homotopy.
    frames : stage-3 dict, optional
        The morph's frames (:func:`conformorph.pipelines.face_morph.frames.compute_frames`,
        same ``reg``, ``times`` and ``curvature``): when every key time is a frame
        time, the main variant's key frames are taken from it
        (:func:`delivered_key_frames`, identical values) instead of solved again.
    bounds : dict, optional
        Filled with method → (N + 1) error bounds of the figures (0 where exact).

    Returns
    -------
    dict
        Method → (N + 1) L2 errors; ``linear`` (the placed keys: 0 up to resampling).
    """
    from conformorph.geometry.sampled_surface_error import sampled_surface_l2
    from conformorph.geometry.surface_distance import SurfaceDistance
    from conformorph.geometry.threads import map_in_threads

    F = reg["cm_F"]
    # each input's search structure, made once for every method
    inputs = map_in_threads(lambda m: SurfaceDistance(*m), list(meshes))
    delivered = delivered_key_frames(frames, times) if reg["meta"]["method"] != "linear" else None
    frames_of: dict[str, NDArray[np.float64]] = {}
    for v, name in registration_variants(reg).items():
        if name == "linear":
            continue
        Vk = delivered if v == "main" and delivered is not None else None
        if Vk is None:
            Vk = morph_variant_frames(reg, times, times, variant=v, curvature=curvature)
        frames_of[name] = Vk
    frames_of["linear"] = placed_keys(reg, "main")
    # every (method, key) comparison is independent: side by side on threads
    jobs = [(name, i) for name in frames_of for i in range(times.size)]

    def l2(job: tuple[str, int]) -> dict[str, float]:
        name, i = job
        X = frames_of[name][i]
        return sampled_surface_l2(
            X, F, *meshes[i], true_surface=inputs[i], samples=KEY_METRIC_SAMPLES
        )

    km: dict[str, list[float]] = {name: [] for name in frames_of}
    for (name, _), e in zip(jobs, map_in_threads(l2, jobs), strict=True):
        km[name].append(float(e["L2"]))
        if bounds is not None:
            bounds.setdefault(name, []).append(float(e["L2_bound"]))
    return km


def truth_errors(
    reg: Arrays, times: NDArray[np.float64], truths: Sequence[Truth], curvature: str
) -> dict[str, Any]:
    """Every method's frames at the truths' times against the known surfaces.

    Parameters
    ----------
    reg : stage-2 dict
    times : (N + 1,) float64
        Key times.
    truths : sequence of (t, V_true (p, 3), F_true (q, 3))
    curvature : str

    Returns
    -------
    dict
        ``times`` and method → one :func:`conformorph.geometry.surface_distance.surface_to_surface_error`
        dict per truth; ``linear`` is linear vertex interpolation of the DMT keys.
    """
    from conformorph.geometry.morph_frames import linear_vertex_frames
    from conformorph.geometry.surface_distance import surface_to_surface_error

    F = reg["cm_F"]
    tt = np.array([t for t, _, _ in truths], dtype=np.float64)
    res: dict[str, Any] = {"times": tt.tolist()}
    for v, name in registration_variants(reg).items():
        if name == "linear":
            continue
        Vt = morph_variant_frames(reg, times, tt, variant=v, curvature=curvature)
        res[name] = [
            surface_to_surface_error(Vt[k], F, Vtr, Ftr) for k, (_, Vtr, Ftr) in enumerate(truths)
        ]
    Vl = linear_vertex_frames(times, placed_keys(reg, "main"), tt)
    res["linear"] = [
        surface_to_surface_error(Vl[k], F, Vtr, Ftr) for k, (_, Vtr, Ftr) in enumerate(truths)
    ]
    return res


def _fallback_message(pair_meta: dict[str, Any], fallback: str) -> str:
    """What a pair's DMT fallback means: :data:`DMT_FALLBACKS`, except an MT fallback
    whose every DMT fit failed rather than folded, which names the fit's error."""
    errors = [a.get("error") for a in pair_meta.get("dmt_attempts") or []]
    if fallback == "mt" and errors and all(errors):
        return f"every DMT fit failed ({errors[0]}): the MT map is used for this pair"
    return DMT_FALLBACKS.get(fallback, fallback)


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
        ``composite_folded``, ``composite_folded_before_repair`` (per map to key
        1 … N: triangles it folded before the local repair, whose details are in
        ``registration.fold_repair``), ``min_jacobian`` (smallest Jacobian determinant
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
                    {"pair": pm["pair"], "fallback": fb, "message": _fallback_message(pm, fb)}
                )
    return {
        "folded_triangles": int(sum(disk) + sum(comp)),
        "disk_map_folded": disk,
        "disk_map_folded_before_repair": before,
        "composite_folded": comp,
        "composite_folded_before_repair": [
            next(
                (
                    r["folded_triangles"]
                    for r in registration.get("fold_repair", [])
                    if r["key"] == i
                ),
                0,
            )
            for i in range(1, len(comp) + 1)
        ],
        "min_jacobian": min(jac) if jac else None,
        "fallbacks": fallbacks,
    }


# --------------------------------------------------------------------------- stage 3


def morph_metrics(
    inputs: Sequence[dict[str, Any]],
    registration: dict[str, Any],
    key_times: NDArray[np.float64],
    frame_times: NDArray[np.float64],
    frames: dict[str, Any],
    files: dict[str, Any],
    seconds: dict[str, Any],
) -> dict[str, Any]:
    """The ``metrics.json`` document of a face morph (JSON-ready).

    Parameters
    ----------
    inputs : sequence of dict
        Stage-1 ``meta`` of every input.
    registration : dict
        Stage-2 ``meta``.
    key_times : (N + 1,) float64
    frame_times : (T,) float64
    frames : dict
        Stage-3 ``meta``.
    files : dict
        Written file → size in bytes.
    seconds : dict
        Time per stage.

    Returns
    -------
    dict
        ``inputs, bijectivity, key_times, frame_times, registration, frames, files, seconds``.
    """
    from conformorph.pipelines.jsonable import jsonable

    out: dict[str, Any] = jsonable(
        {
            "inputs": list(inputs),
            "bijectivity": bijectivity_summary(inputs, registration),
            "key_times": np.asarray(key_times).tolist(),
            "frame_times": np.asarray(frame_times).tolist(),
            "registration": registration,
            "frames": frames,
            "files": files,
            "seconds": seconds,
        }
    )
    return out
