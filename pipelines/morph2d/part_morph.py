"""Shapes of several parts: each matched pair morphed by the strain method, the rest grown or shrunk.

Steps (:func:`morph_parts`):

1. pair the parts (:func:`conformorph.pipelines.morph2d.part_matching.match_parts`;
   anchors pin the pairs they fall in and seed that pair's correspondence);
2. morph each pair as a one-part shape: correspondence, working resolution,
   compatible meshes, strain frames (eq. 2/3, eq. 9–12), at the same times;
3. a part without a partner keeps its own mesh and scales about its pole of
   inaccessibility (the interior point farthest from its outline): a source
   part shrinks into that point, a target part grows out of it; parts that
   grow (or shrink) close together (convex hulls that meet) share the centre
   of the largest of them, so the group scales as one and its parts stay
   apart. The scale never reaches 0: it stops at ``VANISH_SCALE`` so that the
   triangles keep a positive area in every frame (a speck 1/1000 of its size
   shows as nothing). The point is taken beside the other shape (the pole of the
   part less the other shape's parts) so that the speck does not rest inside one
   of them; when parts still overlap, it is moved out of what the other parts
   cover or sweep while it is a speck, kept when that lowers the count
   (:mod:`conformorph.pipelines.morph2d.growth_schedules`); last, all shrinking
   parts scale about one point left of every part and all growing parts about
   one right of them, which keeps a shape that dissolves as a whole clean
   whatever its parts (``growth_schedules._aside``);
4. the parts are one mesh of several components, and every frame is checked
   with shapely: an outline that crosses itself, or two parts that overlap.
   When parts overlap, the growing and shrinking are re-timed (``SCHEDULES``:
   shrinking in the first half and growing in the second, the reverse, both
   within a fifth of the morph at its ends, and last one after the other:
   parts shrink while the matched pairs wait, the pairs morph in the middle
   three fifths, blended between their two nearest frames, and parts grow
   while the pairs rest), and the schedule with fewest crossing frames is
   kept. When parts still cross, the dearest pair (not pinned by anchors) is
   separated: its source part shrinks and its target part grows instead, kept
   only when that lowers the count, then the next dearest, down to the last
   pair (a part that vanishes around a matched part, one in its hole, cannot
   shrink without passing over it: its winding number about it goes from 1 to
   0); when parts cross still, every pair not pinned is separated at once (the
   two shapes then shrink and grow as wholes), kept when that lowers the
   count. Each trial settles its points afresh from the parts' own. A pair
   the strain method cannot morph (no compatible meshes, or the target not
   reached) is separated too, with the reason. What remains is reported
   (``parts.overlapping_frames``, ``parts.self_crossing_frames``,
   ``parts.fallback_pairs`` in ``metrics.json``, and on the command line),
   never silently emitted.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from conformorph.geometry.shape_rings import ShapeRings, points_in_shape
from conformorph.pipelines.morph2d.compatible_meshes import morph2d_meshes
from conformorph.pipelines.morph2d.correspondence import corresponding_anchors, working_resolution
from conformorph.pipelines.morph2d.growth_schedules import (
    LonePart,
    LoneParts,
    PartPair,
    lone_part,
    settled_schedule,
)
from conformorph.pipelines.morph2d.inputs import Morph2DInputs
from conformorph.pipelines.morph2d.options import ANCHORLESS_FALLBACKS, Morph2DOptions
from conformorph.pipelines.morph2d.part_matching import PartMatching, match_parts
from conformorph.pipelines.morph2d.rigid_motion import reference_points
from conformorph.pipelines.morph2d.strain_interpolation import StrainFrames, strain_frames


@dataclass(frozen=True)
class PartsMorph:
    """The morph of two shapes of several parts, as one mesh of several components.

    Attributes
    ----------
    frames : (T, n, 2) float64
    F : (m, 3) int64
    source_V, target_V : (n, 2) float64
        First and last frame's vertices (unmatched parts at their speck size).
    times : (T,) float64
    pairs : list of PartPair
    matching : PartMatching
    info : dict
        The ``parts`` section of ``metrics.json``.
    """

    frames: NDArray[np.float64]
    F: NDArray[np.int64]
    source_V: NDArray[np.float64]
    target_V: NDArray[np.float64]
    times: NDArray[np.float64]
    pairs: list[PartPair | None]
    matching: PartMatching
    info: dict[str, Any]


def _pair_morph(
    source: ShapeRings, target: ShapeRings, seeds: NDArray[np.float64], opts: Morph2DOptions
) -> PartPair:
    inputs = Morph2DInputs(source, target, seeds, [], None, "seeds", None)
    chosen = corresponding_anchors(inputs)
    budget = opts.point_budget
    inputs, resolution = working_resolution(chosen.inputs, budget)
    meshes = morph2d_meshes(inputs)
    after = ANCHORLESS_FALLBACKS[opts.interp] if seeds.shape[0] == 0 else None
    run = strain_frames(
        meshes, reference_points(inputs.anchors), opts.frames, opts.interp, opts.solver, after
    )
    return PartPair(meshes, run, chosen.info | {"working_resolution": resolution}, chosen.document)


def anchor_pins(
    source: list[ShapeRings],
    target: list[ShapeRings],
    anchors: NDArray[np.float64],
    anchor_parts: NDArray[np.int64] | None = None,
) -> NDArray[np.int64]:
    """The part pair of each anchor: given (``anchor_parts``), else the parts containing its points.

    Parameters
    ----------
    source, target : list of ShapeRings
    anchors : (a, 2, 2) float64
    anchor_parts : (a, 2) int64, optional
        ``[source part, target part]`` per anchor (the anchors file's ``parts``).

    Returns
    -------
    (a, 2) int64

    Raises
    ------
    ValueError
        An anchor outside every part of its shape, or not in the part it names.
    """
    out = np.zeros((anchors.shape[0], 2), dtype=np.int64)
    for side, parts in ((0, source), (1, target)):
        inside = np.array([points_in_shape(p, anchors[:, side]) for p in parts]).reshape(
            len(parts), -1
        )
        for i in range(anchors.shape[0]):
            if anchor_parts is not None:
                k = int(anchor_parts[i, side])
                if not 0 <= k < len(parts) or not inside[k, i]:
                    raise ValueError(f"anchor {i} does not lie in part {k} of its shape")
                out[i, side] = k
            elif not inside[:, i].any():
                name = "source" if side == 0 else "target"
                raise ValueError(f"anchor {i} lies outside every part of the {name} shape")
            else:
                out[i, side] = int(np.argmax(inside[:, i]))
    return out


def morph_parts(
    source: list[ShapeRings],
    target: list[ShapeRings],
    anchors: NDArray[np.float64],
    opts: Morph2DOptions,
    anchor_parts: NDArray[np.int64] | None = None,
    failures: dict[tuple[int, int], str] | None = None,
) -> PartsMorph:
    """Morph two shapes of several parts (see the module notes).

    Parameters
    ----------
    source, target : list of ShapeRings
        The parts, largest first.
    anchors : (a, 2, 2) float64
        Anchors (possibly none): each pins the pair of parts it lies in and
        seeds that pair's correspondence.
    opts : Morph2DOptions
    anchor_parts : (a, 2) int64, optional
        The part pair of each anchor, as the anchors file names it.
    failures : dict, optional
        ``{(source part, target part): reason}``: pairs already known not to morph
        (the one-part morph that failed before falling back here), separated
        without being tried again when the matching pairs them.

    Returns
    -------
    PartsMorph
    """
    where = anchor_pins(source, target, anchors, anchor_parts)
    matching = match_parts(source, target, [(int(w[0]), int(w[1])) for w in where])
    pairs, failed = _pairs_morphed(source, target, anchors, where, matching, opts, failures or {})
    times = np.linspace(0.0, 1.0, opts.frames)  # as strain_frames takes them
    whole = {
        side: shapely.union_all([shapely.Polygon(p.outer, list(p.holes)) for p in parts])
        for side, parts in (("s", source), ("t", target))
    }

    def alone(side: str, i: int) -> LonePart:
        shape, other = (source[i], whole["t"]) if side == "s" else (target[i], whole["s"])
        return (*lone_part(shape, other), side == "t")

    lone = {("s", int(i)): alone("s", int(i)) for i in matching.unmatched_source}
    lone |= {("t", int(j)): alone("t", int(j)) for j in matching.unmatched_target}
    for k in failed:
        i, j = (int(x) for x in matching.pairs[k])
        lone[("s", i)] = alone("s", i)
        lone[("t", j)] = alone("t", j)
    keep = [k not in failed for k in range(len(pairs))]
    best, keep = _separations(pairs, keep, lone, matching, alone, times)
    _, schedule, frames, F, tried = best
    info = {
        "fallback_pairs": len(failed),
        "source_parts": len(source),
        "target_parts": len(target),
        "matching": matching.as_dict(),
        "pairs": [
            _pair_info(int(i), int(j), p, kept, failed.get(k))
            for k, ((i, j), p, kept) in enumerate(zip(matching.pairs, pairs, keep, strict=True))
        ],
        "unmatched": (
            "grow out of / shrink into a point: the part's pole of inaccessibility, moved"
            " off what covers it; when parts still cross, one point left of all parts for"
            " the shrinking and one right of them for the growing"
        ),
        "schedule": schedule,
        "schedules_tried": tried,
        **tried[schedule],
    }
    return PartsMorph(frames, F, frames[0], frames[-1], times, pairs, matching, info)


def _separations(
    pairs: list[PartPair | None],
    keep: list[bool],
    lone: LoneParts,
    matching: PartMatching,
    alone: Callable[[str, int], LonePart],
    times: NDArray[np.float64],
) -> tuple[
    tuple[tuple[int, int], str, NDArray[np.float64], NDArray[np.int64], dict[str, Any]], list[bool]
]:
    """The settled schedule (:func:`settled_schedule`) after separating, while parts cross,
    the dearest pairs not pinned one by one (each kept when it lowers the count), then
    all of them at once; and which pairs still morph."""
    base = dict(lone)
    best = settled_schedule(pairs, keep, lone, times)
    pinned = {(int(i), int(j)) for i, j in matching.pinned}
    for k in np.argsort(-matching.cost, kind="stable"):  # dearest pair first
        if best[0] == (0, 0):
            break
        i, j = (int(x) for x in matching.pairs[k])
        if (i, j) in pinned or not keep[k]:
            continue
        # a pair that crosses another: the source part shrinks, the target's grows instead
        extra = {("s", i): alone("s", i), ("t", j): alone("t", j)}
        trial_keep = [x and n != k for n, x in enumerate(keep)]
        # settled afresh from the parts' own points, not from those moved for other pairs
        trial = settled_schedule(pairs, trial_keep, base | extra, times)
        if trial[0] < best[0]:
            best, keep, base = trial, trial_keep, base | extra
    free = [
        k for k, (i, j) in enumerate(matching.pairs) if keep[k] and (int(i), int(j)) not in pinned
    ]
    if best[0] != (0, 0) and free:
        # still crossing: every pair not pinned shrinks and grows (the whole shapes then
        # shrink into a point and grow out of one, which never crosses when the points
        # are free), kept only when that lowers the count
        extra = {}
        for k in free:
            i, j = (int(x) for x in matching.pairs[k])
            extra |= {("s", i): alone("s", i), ("t", j): alone("t", j)}
        trial_keep = [x and n not in free for n, x in enumerate(keep)]
        trial = settled_schedule(pairs, trial_keep, base | extra, times)
        if trial[0] < best[0]:
            best, keep = trial, trial_keep
    return best, keep


def _pairs_morphed(
    source: list[ShapeRings],
    target: list[ShapeRings],
    anchors: NDArray[np.float64],
    where: NDArray[np.int64],
    matching: PartMatching,
    opts: Morph2DOptions,
    known: dict[tuple[int, int], str],
) -> tuple[list[PartPair | None], dict[int, str]]:
    """Each matched pair morphed; a pair the strain method cannot morph (its meshes cannot
    be built, or it does not reach the target) is None, with the reason, unless anchors
    pinned it (then the error is the user's to see); a pair in ``known`` is not tried."""
    pinned = {(int(i), int(j)) for i, j in matching.pinned}
    pairs: list[PartPair | None] = []
    failed: dict[int, str] = {}
    for k, (i, j) in enumerate(matching.pairs):
        mine = (where[:, 0] == i) & (where[:, 1] == j)
        if (int(i), int(j)) in known and (int(i), int(j)) not in pinned:
            pairs.append(None)
            failed[k] = known[(int(i), int(j))]
            continue
        try:
            pair = _pair_morph(source[i], target[j], anchors[mine], opts)
        except (ValueError, ArithmeticError) as exc:
            if (int(i), int(j)) in pinned:
                raise
            pairs.append(None)
            failed[k] = f"{type(exc).__name__}: {exc}"
            continue
        if not pair.run.used["reached_target"] and (int(i), int(j)) not in pinned:
            failed[k] = missed_target(pair.run)
        pairs.append(pair)
    return pairs, failed


def _pair_info(
    i: int, j: int, p: PartPair | None, kept: bool, failure: str | None
) -> dict[str, Any]:
    """One pair's entry of ``metrics.json``'s ``parts.pairs``."""
    out: dict[str, Any] = {"source_part": i, "target_part": j, "separated": not kept}
    if failure is not None:
        out["fallback"] = f"{failure}; the source part shrinks and the target part grows instead"
    if p is not None:
        out |= {
            "interp_used": p.run.interp_used,
            "interp_fallback": p.run.fallback,
            "reached_target": bool(p.run.used["reached_target"]),
            "target_error": p.run.used["target_error"],
            "vertices": int(p.meshes.source_V.shape[0]),
            "correspondence": p.correspondence,
        }
    return out


def missed_target(run: StrainFrames) -> str:
    """Why a pair whose strain morph missed the target is shrunk and grown instead."""
    return (
        f"the strain morph did not reach the target (last frame "
        f"{run.used['target_error']:.3g} of its size away)"
    )


def with_parts_pace(opts: Morph2DOptions) -> Morph2DOptions:
    """The options a several-part morph runs with: every pair on the same frame times
    (``pace="even"`` re-times each pair differently, so it is not applied)."""
    return replace(opts, pace="strain")
