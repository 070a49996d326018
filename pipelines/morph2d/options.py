"""Options of the 2D strain-field morph (:func:`conformorph.pipelines.morph2d.run.run_morph2d`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from conformorph.geometry.strain_morph import StrainMorphOptions
from conformorph.pipelines.animation_loop import DEFAULT_LOOP, LOOP_MODES
from conformorph.pipelines.glb_placement import DEFAULT_SVG_UNITS, GlbPlacement
from conformorph.pipelines.morph2d.errors import tag_field
from conformorph.pipelines.shape_io import DEFAULT_MAX_POINTS

#: ``progress(current, total, stage)`` after each step of the pipeline.
ProgressFn = Callable[[int, int, str], None]

#: Strain schemes tried, in order, after the requested one fails to converge.
FALLBACKS = {
    "principal": ("modified", "linear"),
    "modified": ("principal", "linear"),
    "linear": ("principal", "modified"),
}

#: The fallbacks of a pair given without the user's anchors, which shrinks and grows
#: instead when no scheme reaches the target (:func:`conformorph.pipelines.morph2d.run.run_morph2d`):
#: the paper's eq. (3) in the x/y frame is not tried after another scheme failed. On
#: the icon corpus's tuning split (``benchmarks/bench_icons.py --split tuning``, December
#: 2026), of 74 anchor-free pairs that reached the target 70 did with the principal
#: scheme, 3 with eq. (2) and 1 with eq. (3); on four pairs where every scheme failed,
#: eq. (3)'s attempt took 5.8-56.7 s of the attempts' 15-80 s (a loaded machine).
ANCHORLESS_FALLBACKS = {
    scheme: tuple(s for s in after if s != "modified") for scheme, after in FALLBACKS.items()
}

#: The default strain scheme: eq. (3) in each triangle's principal frame. The paper's
#: eq. (3) interpolates the stretches of the x and y line elements and the shear apart,
#: so its path depends on how the shapes lie in the plane, and at large shears it
#: prescribes strains no placement realises (the minimiser folds or stalls); in the
#: principal frame U_t = (1 − t) I + t U is frame independent and always realisable.
#: Measured (``benchmarks/bench_outline_matching.py``, 19 anchor-free pairs, 60
#: frames): eq. (3) first reached 6 of the 19 pairs itself and fell back on the other
#: 13 after 480–1,070 wasted Newton iterations (whole CLI 1.2–8.5 s a pair); principal
#: first reaches all 19 itself, 1.1–4.2 s. ``interp="modified"`` is the paper's eq. (3).
DEFAULT_INTERP = "principal"


@dataclass(frozen=True)
class Morph2DOptions:
    """What :func:`conformorph.pipelines.morph2d.run.run_morph2d` computes and writes.

    Attributes
    ----------
    frames : int
        Number of frames including source and target (≥ 2; default 60).
    interp : {"principal", "modified", "linear"}
        Strain interpolation: eq. (3) in each triangle's principal frame (default,
        see :data:`DEFAULT_INTERP`), the paper's eq. (3) in the x/y frame, or eq.
        (2). When it does not converge the other schemes are tried in the order of
        ``FALLBACKS``; ``metrics.json`` records the
        scheme used (``interp_used``, per frame under ``methods.strain.frames``)
        and why (``interp_fallback``, ``attempts``).
    pace : {"strain", "even"}
        ``"strain"`` (default): frame k is the strain scheme at t = k/(frames − 1),
        as the paper. ``"even"``: the same path played at the parameter values
        where the largest vertex move is equal between consecutive frames
        (:func:`conformorph.pipelines.morph2d.pacing.even_paced_frames`), which removes eq.
        (3)'s snap at large shears; kept only when it also reaches the target.
    per_frame : bool
        Also write ``frames/NNN.glb`` (default False).
    loop : {"once", "repeat", "alternate"}
        How ``animation.svg`` plays: once, holding the last frame (default),
        repeated, or there and back (:mod:`conformorph.pipelines.animation_loop`).
    max_points : int
        Most points per shape, all rings together
        (``conformorph.pipelines.shape_io.DEFAULT_MAX_POINTS``).
    point_budget : int or None
        Working resolution: most points per shape, all rings together, after
        simplifying each shape keeping its features and every anchor
        (:func:`conformorph.pipelines.morph2d.correspondence.working_resolution`); 0: no
        simplification; None (the default): the anchors file's
        ``point_budget`` if it has one, else
        ``conformorph.pipelines.morph2d.correspondence.DEFAULT_POINT_BUDGET`` when the
        anchors are chosen automatically and none for a user's full list.
        ``max_points`` still refuses larger inputs.
    units : str
        What one SVG user unit is in the GLBs (``px`` default: 96 dpi; ``pt``, ``in``,
        ``mm``, ``cm``, ``m``); :mod:`conformorph.pipelines.glb_placement`.
    size : float or None
        The GLBs' larger side in metres instead of ``units`` (default None).
    solver : StrainMorphOptions
        Knobs of :func:`conformorph.geometry.strain_morph.strain_morph` (tolerance, iteration
        caps, ``max_time_step`` …), the same for every scheme tried (default
        ``StrainMorphOptions()``). Its ``max_total_iterations`` None (the
        default) means the pipeline's budget of ``STRAIN_ITERATIONS_PER_STEP``
        iterations per solver time step, not unlimited; its ``stall_iterations``
        None means ``STRAIN_STALL_ITERATIONS`` (an attempt that spends that many
        iterations without advancing in t stops there and the next scheme is
        tried).
    """

    frames: int = 60
    interp: str = DEFAULT_INTERP
    pace: str = "strain"
    per_frame: bool = False
    loop: str = DEFAULT_LOOP
    max_points: int = DEFAULT_MAX_POINTS
    point_budget: int | None = None
    solver: StrainMorphOptions = field(default_factory=StrainMorphOptions)
    units: str = DEFAULT_SVG_UNITS
    size: float | None = None


def check_morph2d_options(options: Morph2DOptions) -> None:
    """Raise ValueError, tagged with the option's name, for an option out of range.

    Parameters
    ----------
    options : Morph2DOptions

    Raises
    ------
    ValueError
        ``conformorph_field`` is "frames", "interp", "pace", "loop" or "point_budget".
    """
    if options.frames < 2:
        raise tag_field(ValueError(f"frames must be at least 2, got {options.frames}"), "frames")
    if options.interp not in FALLBACKS:
        raise tag_field(
            ValueError(
                f"interp must be 'principal', 'modified' or 'linear', got {options.interp!r}"
            ),
            "interp",
        )
    if options.point_budget is not None and not (
        options.point_budget == 0 or options.point_budget >= 3
    ):
        raise tag_field(
            ValueError(f"point_budget must be 0 or at least 3, got {options.point_budget}"),
            "point_budget",
        )
    try:
        GlbPlacement(options.units, options.size)
    except ValueError as exc:
        raise tag_field(exc, "size" if "size" in str(exc) else "units") from None
    if options.loop not in LOOP_MODES:
        raise tag_field(
            ValueError(f"loop must be one of {', '.join(LOOP_MODES)}; got {options.loop!r}"),
            "loop",
        )
    if options.pace not in ("strain", "even"):
        raise tag_field(
            ValueError(f"pace must be 'strain' or 'even', got {options.pace!r}"), "pace"
        )
