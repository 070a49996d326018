"""The frames of the strain morph, with the fallbacks between strain schemes.

:func:`conformorph.geometry.strain_morph.strain_morph` interpolates the strain field (eq. 2
or eq. 3) and solves every frame (eq. 9–12). When the requested scheme does not
reach the target the others are tried in the order of
:data:`conformorph.pipelines.morph2d.options.FALLBACKS`; every attempt is recorded.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.green_lagrange_strain import StrainScheme, signed_areas
from conformorph.geometry.point_location import locate_points
from conformorph.geometry.strain_morph import StrainMorphInfo, StrainMorphOptions, strain_morph
from conformorph.pipelines.morph2d.compatible_meshes import CompatibleMeshes
from conformorph.pipelines.morph2d.options import FALLBACKS
from conformorph.pipelines.morph2d.strain_metrics import strain_metrics

#: Newton iterations one strain-morph attempt may spend per solver time step
#: (``StrainMorphOptions.max_total_iterations``), so that a hopeless scheme ends
#: instead of running for many minutes before the next is tried. The morphs of
#: ``benchmarks/bench_morph2d.py`` that reach their targets spend 2 (annulus) to 20
#: (stick figures, eq. 2) per step; S -> U with anchors pairing different strokes
#: spent 840 s (2 cores) on one scheme without reaching U.
STRAIN_ITERATIONS_PER_STEP = 50

#: Newton iterations an attempt may spend without its time advancing by half a
#: solver time step before it stops as stalled (``StrainMorphOptions.stall_iterations``)
#: and the next scheme is tried: a rule on progress in t. It replaced a limit of 4
#: halvings per time step, which stopped schemes that would have recovered and made
#: the result depend on the frame count and on round-off: horse → star with the
#: committed anchors (2,673 vertices) reached the target with it on one machine and
#: stalled in every scheme on another; at ``--frames 12`` it stalled. Measured with
#: the total-area bound (``StrainMorphOptions.monotone_area``): horse → star with the
#: committed anchors at the working resolution (1,049 vertices) reaches the target
#: at 12 and 60 frames with 150 or 300 (eq. 3 in the principal frame, 299 and 453
#: iterations); on the 19 anchor-free pairs of ``benchmarks/bench_outline_matching.py``
#: 150 and 300 reach the same 15 targets with the same iterations of the scheme used,
#: and 150 makes the failing attempts cheaper (horse → chair 908 → 574 iterations of
#: the scheme shown, B → C 776 → 644); but with 150 eq. (3) on S → U with the
#: committed anchors (31 frames) stalls where 300 lets it reach the target (450
#: iterations; eq. 3 in the principal frame is used instead): 300 is kept.
STRAIN_STALL_ITERATIONS = 300


def scale_separated_strain_morph(
    S: NDArray[np.float64],
    T: NDArray[np.float64],
    F: NDArray[np.int64],
    times: NDArray[np.float64],
    scheme: str,
    reference: NDArray[np.float64],
    solver: StrainMorphOptions,
) -> tuple[NDArray[np.float64], StrainMorphInfo]:
    """The strain morph of S into T with the uniform scale between them taken out and put back.

    Eq. (2) and (3) interpolate the strain of every triangle from zero; when the
    target is much smaller than the source (horse → chair: 0.29 of its area), every
    strain is far from zero and near t = 1 a small step in t is a large step in
    shape (eq. 2: the metric ``I + t(C − I)`` of a triangle whose final metric C
    has an eigenvalue 0.02 is still 0.037 at t = 59/60); the solver's path then
    stalls in the last frames. Here the target is scaled about the origin by
    ``k = √(area S / area T)`` (equal areas), morphed by
    :func:`conformorph.geometry.strain_morph.strain_morph`, and every frame is scaled
    back about the reference point A by ``k^(−t)`` with A carried to
    ``(1 − t) A⁰ + t Aⁿ`` (Aⁿ its image in T): frame 0 is S, the last frame (t = 1)
    T to the solver's tolerance times 1/k. Measured (no anchors, 60 frames): horse →
    chair reached the target only with the relaxation of the compatible map converged
    to 1e-5 and then on eq. 2 alone (eq. 3 and its principal frame stalled at frames
    56–58 of 60, 48 units from it at t = 0.983, the horse being 588 wide); with the scale
    taken out eq. 3 in the principal frame reaches it, and the 18 other pairs still do.

    Parameters
    ----------
    S, T : (n, 2) float64
    F : (m, 3) int64
    times : (k,) float64
    scheme : {"modified", "linear", "principal"}
    reference : (2, 2) float64
        Reference points A⁰, B⁰ in S.
    solver : StrainMorphOptions

    Returns
    -------
    frames : (k, n, 2) float64
    info : StrainMorphInfo
        Of the morph into the scaled target.
    """
    k = float(np.sqrt(signed_areas(S, F).sum() / signed_areas(T, F).sum()))
    seq, info = strain_morph(
        S,
        k * T,
        F,
        times,
        scheme=cast(StrainScheme, scheme),
        reference_points=reference,
        options=solver,
    )
    if k == 1.0:
        return seq, info
    loc = locate_points(S, F, reference[:1])
    corners = F[loc.triangle[0]]
    bc = loc.barycentric[0]
    a_scaled = np.einsum("k,tkd->td", bc, seq[:, corners])  # A in every scaled frame
    a_end = bc @ T[corners]
    t = times[:, None]
    a = (1.0 - t) * reference[0] + t * a_end
    sigma = k ** (-times)
    frames = a[:, None] + sigma[:, None, None] * (seq - a_scaled[:, None])
    return frames, info


def solver_steps(frames: int, solver: StrainMorphOptions) -> int:
    """Time steps the solver takes over [0, 1] for ``frames`` evenly spaced frames.

    Parameters
    ----------
    frames : int
    solver : StrainMorphOptions

    Returns
    -------
    int
        ``max(frames − 1, ⌈1 / max_time_step⌉)``.

    Examples
    --------
    >>> solver_steps(5, StrainMorphOptions(max_time_step=0.1)), solver_steps(61, StrainMorphOptions())
    (10, 60)
    """
    return max(frames - 1, int(np.ceil(1.0 / float(solver.max_time_step))))


def iteration_budget(steps: int) -> int:
    """Newton iterations allowed to one attempt of ``steps`` solver steps.

    Parameters
    ----------
    steps : int

    Returns
    -------
    int
        ``STRAIN_ITERATIONS_PER_STEP · steps``.
    """
    return STRAIN_ITERATIONS_PER_STEP * steps


@dataclass(frozen=True)
class StrainFrames:
    """The strain morph's frames and the record of every scheme tried.

    Attributes
    ----------
    frames : (T, n, 2) float64
        The frames of the scheme used.
    info : StrainMorphInfo
        Its diagnostics.
    times : (T,) float64
        The parameter of every frame.
    attempts : list of dict
        :func:`conformorph.pipelines.morph2d.metrics.strain_metrics` of every scheme tried,
        the requested one first.
    interp_used : str
        The scheme of ``frames``.
    fallback : str or None
        Why another scheme than the requested one was used.
    solver : StrainMorphOptions
        The solver options used (the pipeline's iteration budget filled in).
    pace_used : str
        ``"strain"``, or ``"even"`` once re-timed (:mod:`conformorph.pipelines.morph2d.pacing`).
    """

    frames: NDArray[np.float64]
    info: StrainMorphInfo
    times: NDArray[np.float64]
    attempts: list[dict[str, Any]]
    interp_used: str
    fallback: str | None
    solver: StrainMorphOptions
    pace_used: str = "strain"

    @property
    def used(self) -> dict[str, Any]:
        """The attempt of the scheme used."""
        return next(a for a in self.attempts if a["scheme"] == self.interp_used)


def strain_frames(
    meshes: CompatibleMeshes,
    reference: NDArray[np.float64],
    frames: int,
    interp: str,
    solver: StrainMorphOptions,
    fallbacks: tuple[str, ...] | None = None,
) -> StrainFrames:
    """Frames at t = k/(frames − 1) by strain-field interpolation, falling back between schemes.

    Eq. (3) in the fixed x/y frame can prescribe a strain path along which the
    minimiser folds a triangle when shears are large (I → L stretches some
    triangles tenfold along a diagonal; continuation up to N = 64 and eight
    halvings of the time step do not help, the stuck branch keeps W > 0 at
    t = 1); eq. (2) fails on others (stick figures). The other schemes are tried
    in turn until one reaches the target.

    Parameters
    ----------
    meshes : CompatibleMeshes
    reference : (2, 2) float64
        Reference points A⁰, B⁰ (:func:`conformorph.pipelines.morph2d.rigid_motion.reference_points`).
    frames : int
    interp : {"modified", "linear"}
        The requested scheme, eq. (3) or eq. (2).
    solver : StrainMorphOptions
        ``max_total_iterations`` None becomes the pipeline's budget,
        ``stall_iterations`` None ``STRAIN_STALL_ITERATIONS``.
    fallbacks : tuple of str, optional
        The schemes tried in turn when ``interp`` does not reach the target;
        default ``FALLBACKS[interp]`` (``ANCHORLESS_FALLBACKS[interp]`` for a pair
        without the user's anchors).

    Returns
    -------
    StrainFrames
    """
    S, T, F = meshes.source_V, meshes.target_V, meshes.F
    times = np.linspace(0.0, 1.0, frames)
    if solver.max_total_iterations is None:
        solver = replace(
            solver, max_total_iterations=iteration_budget(solver_steps(frames, solver))
        )
    if solver.stall_iterations is None:
        solver = replace(solver, stall_iterations=STRAIN_STALL_ITERATIONS)

    def attempt(scheme: str) -> tuple[NDArray[np.float64], StrainMorphInfo]:
        return scale_separated_strain_morph(S, T, F, times, scheme, reference, solver)

    seq, info = attempt(interp)
    attempts = [strain_metrics(S, T, F, seq, info, interp)]
    interp_used, fallback = interp, None
    if not attempts[0]["reached_target"]:
        for alt in FALLBACKS[interp] if fallbacks is None else fallbacks:
            seq2, info2 = attempt(alt)
            attempts.append(strain_metrics(S, T, F, seq2, info2, alt))
            if attempts[-1]["reached_target"]:
                stops = sorted(set(info.stop_reasons) - {"converged"})
                why = (
                    f"did not converge ({stops})"
                    if stops
                    else f"ended {attempts[0]['target_error']:.3g} of the target's size from it"
                )
                fallback = f"{interp} scheme {why}; used {alt}"
                seq, info, interp_used = seq2, info2, alt
                break
    return StrainFrames(seq, info, times, attempts, interp_used, fallback, solver)
