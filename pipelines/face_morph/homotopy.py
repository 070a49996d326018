"""The spline homotopy of the registered keys (section 5 of the face paper): the homotopy's
key arrays of one registration variant, its frames in input coordinates, frame times."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays
from conformorph.pipelines.face_morph.rigid_alignment import similarity


def frame_times_for(times: NDArray[np.float64], frames: int) -> NDArray[np.float64]:
    """``frames`` times from t0 to tN inclusive, every key time among them.

    Parameters
    ----------
    times : (N + 1,) float64
        Key times, strictly increasing.
    frames : int
        Frame count, ≥ 2.

    Returns
    -------
    (max(frames, N + 1),) float64
        The ``frames − 1`` intervals are shared among the N key intervals in proportion
        to their durations (largest remainders, at least one each), and spaced evenly
        within each, so a key is always a frame (``--frames 30`` over keys 0, 1, 2 puts
        frame 15 on key 1) and the spacing is as even as that allows. With two keys this
        is ``linspace(t0, t1, frames)``. Fewer frames than keys get one frame per key.
    """
    if frames < 2:
        raise ValueError(f"--frames must be ≥ 2, got {frames}")
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    n_seg = t.size - 1
    if n_seg < 1:
        raise ValueError(f"need at least 2 key times, got {t.size}")
    intervals = max(int(frames) - 1, n_seg)
    share = np.diff(t) / (t[-1] - t[0]) * intervals
    count = np.maximum(np.floor(share).astype(np.int64), 1)
    while count.sum() > intervals:  # the minimum of one each overshot: take from the largest
        count[np.argmax(count - share)] -= 1
    order = np.argsort(-(share - count), kind="stable")
    for i in range(int(intervals - count.sum())):
        count[order[i % n_seg]] += 1
    pieces = [np.linspace(t[i], t[i + 1], int(count[i]) + 1)[:-1] for i in range(n_seg)]
    return np.concatenate([*pieces, t[-1:]])


def check_frame_times(frame_times: Sequence[float]) -> NDArray[np.float64]:
    """Explicit frame times as an array: at least one, finite, strictly increasing."""
    ft = np.asarray(frame_times, dtype=np.float64).reshape(-1)
    if ft.size < 1:
        raise ValueError("--frame-times needs at least one time")
    if not np.all(np.isfinite(ft)) or np.any(np.diff(ft) <= 0):
        raise ValueError(f"--frame-times must be finite and strictly increasing, got {ft.tolist()}")
    return ft


def homotopy_keys(
    reg: Arrays, v: str, times: NDArray[np.float64], curvature: str
) -> tuple[Any, Any]:
    """The keys and solve options of :func:`conformorph.geometry.morph_frames.morph_frames` for variant ``v``.

    Returns
    -------
    keys : HomotopyKeys
        Times, disk positions, λ, curvature (``Hn``, or scalar ``H`` for
        ``"scalar"``), boundary, transforms; edge lengths for ``"metric"`` and
        ``"screened"``, key positions for ``"screened"``.
    options : FrameSolveOptions
        ``screen_weight`` :data:`conformorph.geometry.morph_frames.SCREEN_WEIGHT` for ``"screened"``.
    """
    from conformorph.geometry.morph_frames import SCREEN_WEIGHT, FrameSolveOptions, HomotopyKeys

    X = reg[f"key_X__{v}"]
    key_lengths = key_positions = None
    if curvature in ("metric", "screened"):
        from conformorph.geometry.intrinsic_laplacian import edge_lengths

        key_lengths = np.stack([edge_lengths(x, reg["cm_F"]) for x in X])
    if curvature == "screened":
        key_positions = X
    keys = HomotopyKeys(
        times=times,
        key_uv=reg[f"key_uv__{v}"],
        key_lam=reg[f"key_lam__{v}"],
        key_curvature=reg[f"key_Hn__{v}"] if curvature != "scalar" else reg[f"key_H__{v}"],
        key_boundary=X[:, reg["cm_b"]],
        transforms=key_similarities(reg),
        key_lengths=key_lengths,
        key_positions=key_positions,
    )
    options = FrameSolveOptions(screen_weight=SCREEN_WEIGHT if curvature == "screened" else 0.0)
    return keys, options


def key_similarities(reg: Arrays) -> list[Any]:
    """The similarities aligned frame → input of every key (``key_R, key_t, key_s``)."""
    return [
        similarity(reg["key_R"][i], reg["key_t"][i], reg["key_s"][i])
        for i in range(reg["key_R"].shape[0])
    ]


def placed_keys(reg: Arrays, v: str) -> NDArray[np.float64]:
    """Variant ``v``'s keys on the consistent mesh in input coordinates, (N+1, n, 3)."""
    T = key_similarities(reg)
    X = reg[f"key_X__{v}"]
    return np.stack([T[i].apply(X[i]) for i in range(X.shape[0])])


def homotopy_frames(
    reg: Arrays,
    v: str,
    times: NDArray[np.float64],
    frame_times: NDArray[np.float64],
    curvature: str,
) -> Any:
    """The reconstructed frames of variant ``v`` (:func:`conformorph.geometry.morph_frames.morph_frames`)."""
    from conformorph.geometry.morph_frames import morph_frames

    keys, options = homotopy_keys(reg, v, times, curvature)
    return morph_frames(reg["cm_F"], reg["cm_b"], keys, frame_times, options)


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
    from conformorph.geometry.morph_frames import linear_vertex_frames

    if linear:
        return linear_vertex_frames(times, placed_keys(reg, variant), frame_times)
    fr = homotopy_frames(reg, variant, times, frame_times, curvature)
    return np.stack([fr.placed(k) for k in range(frame_times.size)])
