"""Diagnostics of the strain morph: per-frame Newton records, W (eq. 4) and det J."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .green_lagrange_strain import StrainScheme
from .strain_frames import SolvedFrames
from .strain_system import StrainSystem
from .strain_targets import strain_target


@dataclass(frozen=True)
class StrainMorphInfo:
    """Diagnostics of :func:`strain_morph`, one entry per requested time.

    Attributes
    ----------
    times : (T,) float64
        The times of the returned frames.
    iterations : (T,) int64
        Newton iterations spent on each frame, continuation levels and
        inserted sub-steps included (0 for t = 0).
    continuation : (T,) int64
        Largest continuation level N used (eq. 12); 1 means plain Newton.
    substeps : (T,) int64
        Extra time steps inserted before the frame because continuation alone
        failed.
    step_norms : (T,) float64
        Last Newton update ‖ΔV‖_F relative to the bounding-box diagonal.
    energies : (T,) float64
        W (eq. 4) at the solution, relative to the source area.
    min_jacobian : (T,) float64
        Smallest det J (area ratio) over the triangles of each frame; > 0
        means no triangle is flipped.
    stop_reasons : tuple of str
        Per frame: ``"converged"``, ``"max_iterations"`` (best iterate kept),
        ``"flip"`` (every strategy would flip a triangle; the last unflipped
        iterate is kept), ``"budget"`` (``max_total_iterations`` was spent before
        the frame was solved; the last state solved is repeated) or ``"stalled"``
        (``max_step_halvings`` or ``stall_iterations`` was exceeded in this or an
        earlier frame; likewise).
    rotation : float
        R, the angle from A⁰B⁰ to AⁿBⁿ in (−π, π].
    translation : (2,) float64
        T, the vector from A⁰ to Aⁿ.
    seconds : float
        Wall-clock time of the whole solve.
    """

    times: FloatArray
    iterations: IntArray
    continuation: IntArray
    substeps: IntArray
    step_norms: FloatArray
    energies: FloatArray
    min_jacobian: FloatArray
    stop_reasons: tuple[str, ...]
    rotation: float
    translation: FloatArray
    seconds: float

    @property
    def converged(self) -> bool:
        """Whether every frame converged."""
        return all(r == "converged" for r in self.stop_reasons)


def strain_morph_info(
    system: StrainSystem,
    solved: SolvedFrames,
    eps_n: FloatArray,
    times: FloatArray,
    scheme: StrainScheme,
    scales: tuple[float, float],
    rigid: tuple[float, FloatArray],
    seconds: float,
    rest_areas: FloatArray | None = None,
) -> StrainMorphInfo:
    """The diagnostics of solved frames: relative steps, W (eq. 4) per unit area, min det J.

    Parameters
    ----------
    system : StrainSystem
    solved : SolvedFrames
        Frames in the gauge frame, ``T`` of them.
    eps_n : (m, 3) float64
        Final strain field (eq. 1).
    times : (T,) float64
    scheme : {"modified", "linear", "principal"}
    scales : (float, float)
        Bounding-box diagonal and total area of the source.
    rigid : (float, (2,) float64)
        R and T of the rigid motion.
    seconds : float
    rest_areas : (m,) float64, optional
        Given when the frames were solved with the total area made linear in t
        (:func:`conformorph.geometry.strain_targets.strain_target`), so that W is
        measured against the strain each frame was solved for.

    Returns
    -------
    StrainMorphInfo
    """
    diag, total_area = scales
    T_count = times.shape[0]
    step_norms = np.zeros(T_count)
    energies = np.zeros(T_count)
    min_jac = np.zeros(T_count)
    for i, t in enumerate(times):
        X, step = solved.X[i], solved.steps[i]
        step_norms[i] = step / diag if np.isfinite(step) else np.inf
        gain = 1.0 if solved.area_gains is None else float(solved.area_gains[i])
        eps_t, _ = strain_target(eps_n, float(t), scheme, rest_areas, gain)
        energies[i] = system.energy(X, eps_t) / total_area
        min_jac[i] = float(np.min(system.det(X)))
    return StrainMorphInfo(
        times=times.copy(),
        iterations=solved.iterations,
        continuation=solved.continuation,
        substeps=solved.substeps,
        step_norms=step_norms,
        energies=energies,
        min_jacobian=min_jac,
        stop_reasons=solved.stop_reasons,
        rotation=rigid[0],
        translation=np.asarray(rigid[1], dtype=np.float64),
        seconds=seconds,
    )
