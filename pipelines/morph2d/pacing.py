"""Pacing of the morph: the strain path re-timed so that it moves evenly (``pace="even"``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.morph_pacing import even_pace_times
from conformorph.pipelines.morph2d.compatible_meshes import CompatibleMeshes
from conformorph.pipelines.morph2d.strain_interpolation import (
    StrainFrames,
    iteration_budget,
    scale_separated_strain_morph,
    solver_steps,
)
from conformorph.pipelines.morph2d.strain_metrics import strain_metrics

#: samples of the path per output frame from which ``pace="even"`` re-times it
PACE_SAMPLES_PER_FRAME = 4


def even_paced_frames(
    meshes: CompatibleMeshes, reference: NDArray[np.float64], run: StrainFrames
) -> StrainFrames:
    """The same strain path played at parameters where consecutive frames move equally.

    The path of the scheme used is sampled ``PACE_SAMPLES_PER_FRAME`` times per
    frame, re-timed by :func:`conformorph.geometry.morph_pacing.even_pace_times` (equal
    largest vertex moves between frames) and solved again at the new times. This
    removes eq. (3)'s snap at large shears. The re-timed frames replace ``run``'s
    only when the fine path converged and they also reach the target.

    Parameters
    ----------
    meshes : CompatibleMeshes
    reference : (2, 2) float64
        Reference points A⁰, B⁰.
    run : StrainFrames
        Frames at even parameter steps that reached the target.

    Returns
    -------
    StrainFrames
        ``pace_used="even"`` when re-timed, else ``run`` itself.
    """
    S, T, F = meshes.source_V, meshes.target_V, meshes.F
    frames = run.times.shape[0]
    fine_t = np.linspace(0.0, 1.0, PACE_SAMPLES_PER_FRAME * (frames - 1) + 1)
    steps = solver_steps(frames, run.solver)
    fine_opts = replace(
        run.solver, max_total_iterations=iteration_budget(max(steps, fine_t.size - 1))
    )
    scheme = run.interp_used
    fine, fine_info = scale_separated_strain_morph(S, T, F, fine_t, scheme, reference, fine_opts)
    if not fine_info.converged:
        return run
    tau = even_pace_times(fine_t, fine, frames)
    seq, info = scale_separated_strain_morph(S, T, F, tau, scheme, reference, fine_opts)
    paced = strain_metrics(S, T, F, seq, info, run.interp_used)
    if not paced["reached_target"]:
        return run
    used = run.used
    attempts = [paced if a is used else a for a in run.attempts]
    return replace(run, frames=seq, info=info, times=tau, attempts=attempts, pace_used="even")
