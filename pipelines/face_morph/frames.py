"""Stage 3 of the face morph (section 5 of the face paper): the frames of the spline
homotopy of the registered keys, their rigid part interpolated apart, appearance blended
with the same spline; metrics at the keys and against known surfaces when asked."""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.homotopy import homotopy_frames, placed_keys
from conformorph.pipelines.face_morph.metrics import (
    Mesh,
    Truth,
    key_frame_metrics,
    truth_errors,
)
from conformorph.pipelines.face_morph.options import CURVATURE_HOMOTOPIES, Arrays, FrameOptions

LINEAR_BASELINE_NOTE = (
    "linear vertex interpolation reproduces every key exactly and is exact on any path "
    "that is linear in vertex space between keys (e.g. a linear blend-shape path); its "
    "errors below are 0 at the keys by construction, not by merit"
)


def _shape_frames(
    reg: Arrays, times: NDArray[np.float64], frame_times: NDArray[np.float64], curvature: str
) -> tuple[Arrays, list[int]]:
    """The frames of the homotopy's registration (or linear interpolation for ``linear``)."""
    from conformorph.geometry.morph_frames import linear_vertex_frames

    out: Arrays = {}
    if reg["meta"]["method"] == "linear":
        Vf = linear_vertex_frames(times, placed_keys(reg, "main"), frame_times)
        out["frames_V"] = Vf
        out["frames_aligned"] = Vf
        out["frame_R"] = np.broadcast_to(np.eye(3), (frame_times.size, 3, 3)).copy()
        out["frame_t"] = np.zeros((frame_times.size, 3))
        out["frame_s"] = np.ones(frame_times.size)
        return out, []
    fr = homotopy_frames(reg, "main", times, frame_times, curvature)
    out["frames_aligned"] = fr.V
    out["frames_V"] = np.stack([fr.placed(k) for k in range(frame_times.size)])
    out["frame_R"] = np.stack([T.rotation for T in fr.transforms])
    out["frame_t"] = np.stack([T.translation for T in fr.transforms])
    out["frame_s"] = np.array([T.scale for T in fr.transforms])
    return out, list(fr.iterations)


def _appearance_frames(
    reg: Arrays, times: NDArray[np.float64], frame_times: NDArray[np.float64]
) -> Arrays:
    """Vertex colours and texture weights of every frame: the cubic spline in t."""
    from conformorph.geometry.spline_homotopy import SplineHomotopy

    out: Arrays = {}
    if "key_colors__main" in reg:
        col = SplineHomotopy(times, reg["key_colors__main"])(frame_times)
        out["frames_colors"] = np.clip(col, 0.0, 1.0)
    if "key_textures" in reg:
        # the texel colours follow the same cubic spline in t; the spline is linear in
        # its data, so frame k's texture is Σ_i w[k, i] · key texture i with the weights
        # of the spline through the unit vectors (the textures are blended at export)
        K = reg["key_textures"].shape[0]
        out["frame_texture_weights"] = SplineHomotopy(times, np.eye(K))(frame_times)
    return out


def compute_frames(
    reg: Arrays,
    prepared_meshes: Sequence[Mesh],
    times: NDArray[np.float64],
    frame_times: NDArray[np.float64],
    options: FrameOptions | None = None,
    *,
    truths: Sequence[Truth] = (),
) -> Arrays:
    """Stage 3: the homotopy frames and their metrics.

    Parameters
    ----------
    reg : stage-2 dict
    prepared_meshes : sequence of (V (n_i, 3), F (m_i, 3))
        The input meshes (input coordinates), for the key-frame metrics.
    times : (N + 1,) float64
        Key times.
    frame_times : (T,) float64
    options : FrameOptions, optional (default ``FrameOptions()``)
        Curvature homotopy and key-frame metrics.
    truths : sequence of (t, V_true, F_true)
        Known surfaces at times t, compared with every method's frame.

    Returns
    -------
    dict
        ``frames_V (T, n, 3)`` in input coordinates, ``frames_aligned (T, n, 3)``,
        ``frame_R (T, 3, 3)``, ``frame_t (T, 3)``, ``frame_s (T,)``,
        ``frame_times``, optional ``frames_colors (T, n, c)``, optional
        ``frame_texture_weights (T, N + 1)`` (frame k's texture is
        ``Σ_i w[k, i] key_textures[i]``), and ``meta``.
    """
    options = FrameOptions() if options is None else options
    curvature = options.curvature
    if curvature not in CURVATURE_HOMOTOPIES:
        raise ValueError(
            f"curvature must be one of {', '.join(CURVATURE_HOMOTOPIES)}, got {curvature!r}"
        )
    method = reg["meta"]["method"]
    times = np.asarray(times, dtype=np.float64)
    t0 = time.perf_counter()
    out: Arrays = {"frame_times": frame_times}
    shape, iterations = _shape_frames(reg, times, frame_times, curvature)
    out.update(shape)
    out.update(_appearance_frames(reg, times, frame_times))
    t_frames = time.perf_counter()
    meta: dict[str, Any] = {
        "method": method,
        "curvature_homotopy": curvature if method != "linear" else None,
        "n_frames": int(frame_times.size),
        "reconstruction_iterations": iterations,
        "linear_baseline_note": LINEAR_BASELINE_NOTE,
    }
    if options.key_metrics:
        bounds: dict[str, list[float]] = {}
        meta["key_frame_L2_to_inputs"] = key_frame_metrics(
            reg, prepared_meshes, times, curvature, frames=out, bounds=bounds
        )
        meta["key_frame_L2_bound"] = bounds
    if truths:
        meta["truth_errors"] = truth_errors(reg, times, truths, curvature)
    meta["seconds"] = {"frames": t_frames - t0, "metrics": time.perf_counter() - t_frames}
    out["meta"] = meta
    return out
