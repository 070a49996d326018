"""``run_morph2d``: the 2D strain-field morph (Yan, Hu and Martin 2004) as the paper's steps.

The adapter used by the CLI (``conformorph morph2d``) and by the worker stage
behind ``POST /v1/morphs2d``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from conformorph.pipelines.glb_placement import GlbPlacement
from conformorph.pipelines.morph2d.compatible_meshes import CompatibleMeshes, morph2d_meshes
from conformorph.pipelines.morph2d.correspondence import (
    Correspondence,
    corresponding_anchors,
    working_resolution,
)
from conformorph.pipelines.morph2d.errors import MorphNotConvergedError
from conformorph.pipelines.morph2d.frame_crossings import crossing_frames, crossing_reason
from conformorph.pipelines.morph2d.inputs import (
    Morph2DInputs,
    read_morph2d_inputs,
    read_shape_documents,
)
from conformorph.pipelines.morph2d.metrics import baseline_metrics, morph2d_metrics
from conformorph.pipelines.morph2d.options import (
    ANCHORLESS_FALLBACKS,
    Morph2DOptions,
    ProgressFn,
    check_morph2d_options,
)
from conformorph.pipelines.morph2d.outputs import write_metrics_json, write_morph2d_outputs
from conformorph.pipelines.morph2d.pacing import even_paced_frames
from conformorph.pipelines.morph2d.part_morph import missed_target
from conformorph.pipelines.morph2d.rigid_motion import reference_points
from conformorph.pipelines.morph2d.run_parts import run_morph2d_parts
from conformorph.pipelines.morph2d.strain_interpolation import StrainFrames, strain_frames
from conformorph.pipelines.outline_anchors import write_anchors_document
from conformorph.pipelines.shape_io import ShapeDocument

#: The stages reported to ``progress``, in order.
STAGES = ("read", "mesh", "strain", "baselines", "outputs", "done")


def run_morph2d(
    source_path: str | Path,
    target_path: str | Path,
    anchors_path: str | Path | None,
    outdir: str | Path,
    options: Morph2DOptions | None = None,
    *,
    texture_path: str | Path | None = None,
    progress: ProgressFn | None = None,
    require_convergence: bool = True,
) -> dict[str, Any]:
    """Morph one 2D shape into another and write the outputs to ``outdir``.

    Shapes of several parts (an SVG whose painted region has several
    polygons, a JSON ``parts`` document) take
    :func:`conformorph.pipelines.morph2d.run_parts.run_morph2d_parts`: parts
    paired, each pair morphed by the steps below, the rest grown or shrunk.
    So does a one-part pair that the steps below cannot morph when no anchors
    were given (no compatible meshes, the target not reached, or frames where
    the outline crosses itself or a hole its outline, which no strain term
    prevents): the source shrinks into a point and the target grows out of
    one, never crossing, and ``metrics.json`` (``parts.pairs[0].fallback``)
    and the CLI say why. With anchors the error is raised (crossings are
    reported in ``metrics.json``'s ``crossings``), for the user to move them.

    Steps: read and pair the inputs; without a full anchors list, find
    corresponding points of the outlines and pair the holes, then simplify
    the shapes to the working resolution (:mod:`conformorph.pipelines.morph2d.correspondence`);
    build compatible meshes; take the reference
    points A, B of the rigid motion (steps 1 and 5) from the first two anchors;
    interpolate the strain field (eq. 2 / eq. 3) and solve every frame (eq.
    9–12), falling back between schemes; re-time the path (``pace="even"``);
    the baselines; the outputs and ``metrics.json``.

    Parameters
    ----------
    source_path, target_path : str or Path
        Shape files (JSON rings or SVG path data), see :mod:`conformorph.pipelines.shape_io`.
    anchors_path : str or Path or None
        Anchors JSON; the first two anchors are the reference points A, B of
        the rigid-motion removal. None, or a file with fewer than two pairs
        or ``"partial": true``: the anchors are found automatically (seeded
        by the file's, kept first and exactly) and written to
        ``outdir/anchors.json``, a file that can be edited and passed back.
    outdir : str or Path
        Output folder (created).
    options : Morph2DOptions, optional
        Frames, scheme, pacing, per-frame output, point limit, solver knobs.
    texture_path : str or Path, optional
        A PNG image spread over the source's bounding box and carried by
        barycentric coordinates (static UVs) through every frame; checked
        before any numerics.
    progress : callable, optional
        ``progress(current, total, stage)`` after each stage of ``STAGES``.
    require_convergence : bool, optional
        Raise :class:`MorphNotConvergedError` (after writing every output)
        when no scheme reaches the target; False returns the metrics instead.

    Returns
    -------
    dict
        The content of ``metrics.json`` (:func:`conformorph.pipelines.morph2d.metrics.morph2d_metrics`).

    Raises
    ------
    ShapeError (and subclasses), ValueError, OSError, FoldedMapError
        Bad inputs, each with a message naming the problem; errors carry the
        input they concern as ``conformorph_field`` ("source", "target",
        "anchors", "anchors[i][side]", "paths[k]", "texture", "frames",
        "interp", "pace").
    MorphNotConvergedError
        When ``require_convergence`` and the last frame did not reach the target.
    """
    opts = Morph2DOptions() if options is None else options
    check_morph2d_options(opts)
    done = iter(range(1, len(STAGES) + 1))

    def report(stage: str) -> None:
        if progress is not None:
            progress(next(done), len(STAGES), stage)

    t_start = time.perf_counter()

    def by_parts(failures: dict[tuple[int, int], str] | None, stage: str) -> dict[str, Any]:
        # several parts, or (with the reason in ``failures``) one outline that shrinks
        # and one that grows, never crossing
        paths = (source_path, target_path)
        result = run_morph2d_parts(
            docs, paths, anchors_path, outdir, opts, texture_path, t_start, failures
        )
        return _finished(result, report, require_convergence, STAGES.index(stage))

    docs = read_shape_documents(source_path, target_path, opts.max_points)
    if len(docs[0].parts) > 1 or len(docs[1].parts) > 1:
        return by_parts(None, "read")
    inputs = read_morph2d_inputs(
        source_path, target_path, anchors_path, texture_path, opts.max_points, docs
    )
    report("read")
    user_anchors = anchors_path is not None
    steps = _strain_morph(inputs, opts, user_anchors)
    if isinstance(steps, str):  # only without anchors
        return by_parts({(0, 0): steps}, "mesh")
    report("mesh")
    paced = _paced(steps, opts, user_anchors)
    if isinstance(paced, str):
        return by_parts({(0, 0): paced}, "strain")
    report("strain")
    result = _one_part_outputs(
        Path(outdir), paced, docs, (source_path, target_path), opts, t_start, report
    )
    return _finished(result, report, require_convergence, STAGES.index("done"))


@dataclass(frozen=True)
class OnePartMorph:
    """A one-part pair morphed by the strain steps: the correspondence found, the inputs
    at the working resolution and the resolution's record, the compatible meshes, the
    frames, and (once re-timed, :func:`_paced`) their crossings."""

    chosen: Correspondence
    inputs: Morph2DInputs
    resolution: dict[str, Any]
    meshes: CompatibleMeshes
    run: StrainFrames
    crossings: dict[str, Any] | None = None


def _strain_morph(
    inputs: Morph2DInputs, opts: Morph2DOptions, user_anchors: bool
) -> OnePartMorph | str:
    """Correspondence, working resolution, compatible meshes and strain frames of a
    one-part pair. Without ``user_anchors``, a pair
    these steps cannot morph (an error of the meshing, or the target not reached)
    gives the reason instead, for :func:`run_morph2d` to shrink and grow the shapes;
    with them the error is raised (and a missed target reported) for the user to see."""
    try:
        chosen = corresponding_anchors(inputs)
        inputs, resolution = working_resolution(chosen.inputs, opts.point_budget)
        meshes = morph2d_meshes(inputs)
        ref = reference_points(inputs.anchors)
        after = None if user_anchors else ANCHORLESS_FALLBACKS[opts.interp]
        run = strain_frames(meshes, ref, opts.frames, opts.interp, opts.solver, after)
    except (ValueError, ArithmeticError) as exc:
        if user_anchors:
            raise
        return f"{type(exc).__name__}: {exc}"
    if not user_anchors and not run.used["reached_target"]:
        return missed_target(run)
    return OnePartMorph(chosen, inputs, resolution, meshes, run)


def _paced(steps: OnePartMorph, opts: Morph2DOptions, user_anchors: bool) -> OnePartMorph | str:
    """The frames re-timed as ``opts.pace`` asks, and their crossings
    (:func:`conformorph.pipelines.morph2d.frame_crossings.crossing_frames`); without
    ``user_anchors``, the reason instead when frames cross (:func:`crossing_reason`),
    for :func:`run_morph2d` to shrink and grow the shapes. Frames that cross are not
    re-timed first: the re-timing samples the same path."""
    run, meshes = steps.run, steps.meshes
    crossings = crossing_frames(run.frames, meshes.F, run.times)
    reason = None if user_anchors else crossing_reason(crossings, run.times.shape[0])
    if reason is not None:
        return reason
    if opts.pace == "even" and run.used["reached_target"]:
        paced = even_paced_frames(meshes, reference_points(steps.inputs.anchors), run)
        if paced is not run:
            run, crossings = paced, crossing_frames(paced.frames, meshes.F, paced.times)
            reason = None if user_anchors else crossing_reason(crossings, run.times.shape[0])
    return replace(steps, run=run, crossings=crossings) if reason is None else reason


def _one_part_outputs(
    out: Path,
    steps: OnePartMorph,
    docs: tuple[ShapeDocument, ShapeDocument],
    paths: tuple[str | Path, str | Path],
    opts: Morph2DOptions,
    t_start: float,
    report: Callable[[str], None],
) -> dict[str, Any]:
    """The baselines, the outputs and ``metrics.json`` of a one-part morph; returns the
    metrics."""
    run, meshes = steps.run, steps.meshes
    baselines = baseline_metrics(meshes.source_V, meshes.target_V, meshes.F, run.times)
    report("baselines")
    outputs = _write_outputs(
        out, run, meshes, steps.inputs.texture, opts, steps.chosen, steps.resolution
    )
    report("outputs")
    result = morph2d_metrics(paths, opts, meshes, run, baselines, outputs, t_start)
    result["correspondence"] = steps.chosen.info
    result["working_resolution"] = steps.resolution
    result["crossings"] = steps.crossings
    result["svg"] = {"source": list(docs[0].notes), "target": list(docs[1].notes)}
    result["strokes_outlined"] = {"source": docs[0].stroked, "target": docs[1].stroked}
    write_metrics_json(out, result)
    return result


def _write_outputs(
    out: Path,
    run: StrainFrames,
    meshes: CompatibleMeshes,
    texture: bytes | None,
    opts: Morph2DOptions,
    chosen: Correspondence,
    resolution: dict[str, Any],
) -> dict[str, Any]:
    """Write a one-part morph's outputs, and the anchors file when the anchors were found
    (:func:`conformorph.pipelines.morph2d.outputs.write_morph2d_outputs`).

    Returns
    -------
    dict
        The outputs' names, as in ``metrics.json``.
    """
    outputs = write_morph2d_outputs(
        out,
        run.frames,
        meshes.F,
        meshes.source_V,
        texture,
        opts.per_frame,
        run.times,
        GlbPlacement(opts.units, opts.size),
        loop=opts.loop,
    )
    if chosen.document is not None:
        write_anchors_document(
            out / "anchors.json",
            chosen.document | {"point_budget": resolution["point_budget"] or 0},
        )
        outputs["anchors"] = "anchors.json"
    return outputs


def _finished(
    result: dict[str, Any],
    report: Callable[[str], None],
    require_convergence: bool,
    done: int = 0,
) -> dict[str, Any]:
    """Report the stages from ``STAGES[done]`` on; raise when the target was required and missed."""
    for stage in STAGES[done:]:
        report(stage)
    if not result["reached_target"] and require_convergence:
        raise MorphNotConvergedError(str(result["not_converged_reason"]), result)
    return result
