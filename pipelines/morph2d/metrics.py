"""Metrics of the 2D morph: the baselines, why a morph failed, and the content of ``metrics.json``."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.arap_interpolation import arap_interpolation
from conformorph.geometry.linear_interpolation import linear_interpolation
from conformorph.geometry.morph_metrics_2d import morph_metrics_2d
from conformorph.pipelines.morph2d.compatible_meshes import CompatibleMeshes
from conformorph.pipelines.morph2d.options import Morph2DOptions
from conformorph.pipelines.morph2d.strain_interpolation import StrainFrames


def not_converged_reason(
    attempts: list[dict[str, Any]], frames: int, stretch: dict[str, Any] | None = None
) -> str:
    """One line: where each scheme stopped, how far the last frame is from the target and
    how much the compatible meshes stretch their triangles (``stretch``, from
    :func:`conformorph.geometry.map_stretch.map_stretch`): anchors that pair different features of
    the two shapes show as anisotropies in the hundreds (S → U with the corner rule's
    anchors: 493; with its stroke ends paired: 49, and every scheme converges).

    Parameters
    ----------
    attempts : list of dict
        :func:`conformorph.pipelines.morph2d.strain_metrics.strain_metrics` of every scheme tried, the requested one first.
    frames : int
    stretch : dict, optional

    Returns
    -------
    str
    """
    parts = []
    for a in attempts:
        bad = [j for j, f in enumerate(a["frames"]) if not f["converged"]]
        if bad:
            f = a["frames"][bad[0]]
            parts.append(
                f"{a['scheme']} stopped at frame {bad[0]} of {frames} "
                f"(t = {f['t']:.3f}, {f['stop_reason']})"
            )
        else:
            parts.append(
                f"{a['scheme']} converged in every frame but ended {a['target_error']:.3g} "
                "of the target's size from it"
            )
    last = attempts[0]
    return (
        "the strain morph did not reach the target: "
        + "; ".join(parts)
        + f"; the last frame ({last['scheme']}) is {last['target_error']:.3g} of the target's "
        "size from it"
        + (
            f"; the compatible meshes stretch a triangle {stretch['max_stretch']:.3g}-fold, "
            f"shorten one to {stretch['min_stretch']:.3g} and distort one "
            f"{stretch['max_anisotropy']:.3g}-fold (largest / smallest stretch)"
            if stretch
            else ""
        )
        + ". Add anchors where the shapes differ most, on corresponding features"
    )


def baseline_metrics(
    S: NDArray[np.float64], T: NDArray[np.float64], F: NDArray[np.int64], times: NDArray[np.float64]
) -> dict[str, Any]:
    """Metrics of the two baselines at the same parameters: vertex-wise linear and ARAP.

    Parameters
    ----------
    S, T : (n, 2) float64
    F : (m, 3) int64
    times : (k,) float64

    Returns
    -------
    dict
        ``{"linear": …, "arap": …}``, each
        :func:`conformorph.geometry.morph_metrics_2d.morph_metrics_2d` with ``seconds``.
    """
    methods: dict[str, Any] = {}
    t0 = time.perf_counter()
    lin = linear_interpolation(S, T, times)
    methods["linear"] = morph_metrics_2d(S, F, lin).as_dict() | {
        "seconds": time.perf_counter() - t0
    }
    t0 = time.perf_counter()
    arap = arap_interpolation(S, T, F, times)
    methods["arap"] = morph_metrics_2d(S, F, arap).as_dict() | {"seconds": time.perf_counter() - t0}
    return methods


def morph2d_metrics(
    shapes: tuple[str | Path, str | Path],
    options: Morph2DOptions,
    meshes: CompatibleMeshes,
    run: StrainFrames,
    baselines: dict[str, Any],
    outputs: dict[str, Any],
    t_start: float,
) -> dict[str, Any]:
    """The content of ``metrics.json``.

    Parameters
    ----------
    shapes : (str or Path, str or Path)
        Source and target, as given.
    options : Morph2DOptions
    meshes : CompatibleMeshes
    run : StrainFrames
        The frames written, with every scheme's attempt.
    baselines : dict
        :func:`baseline_metrics`.
    outputs : dict
        The files written (``metrics.json`` is added).
    t_start : float
        ``time.perf_counter()`` at the start of the run.

    Returns
    -------
    dict
        Options and what was used (``interp_used``, ``interp_fallback``,
        ``pace_used``, ``frame_t``), ``reached_target`` and
        ``not_converged_reason``, ``attempts``, ``mesh``, ``methods`` (strain,
        linear, arap), ``outputs`` and ``seconds``.
    """
    m = run.used
    reached = bool(m["reached_target"])
    result: dict[str, Any] = {
        "source": str(shapes[0]),
        "target": str(shapes[1]),
        "frames": options.frames,
        "interp": options.interp,
        "interp_used": run.interp_used,
        "interp_fallback": run.fallback,
        "pace": options.pace,
        "pace_used": run.pace_used,
        "loop": options.loop,
        "frame_t": run.times.tolist(),
        "reached_target": reached,
        "not_converged_reason": (
            None
            if reached
            else not_converged_reason(run.attempts, options.frames, meshes.info.get("stretch"))
        ),
        "attempts": [
            {k: a[k] for k in ("scheme", "converged", "reached_target", "target_error")}
            for a in run.attempts
        ],
        "mesh": meshes.info,
        "methods": {"strain": m, **baselines},
        "outputs": outputs,
        "seconds": time.perf_counter() - t_start,
    }
    result["outputs"]["metrics"] = "metrics.json"
    return result
