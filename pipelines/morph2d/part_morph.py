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
   cover while it is a speck (:func:`_rested`), kept when that lowers the count;
4. the parts are one mesh of several components, and every frame is checked
   with shapely: an outline that crosses itself, or two parts that overlap.
   When parts overlap, the growing and shrinking are re-timed (``SCHEDULES``:
   shrinking in the first half and growing in the second, the reverse, both
   within a fifth of the morph at its ends, and last one after the other:
   parts shrink while the matched pairs wait, the pairs morph in the middle
   three fifths, blended between their two nearest frames, and parts grow
   while the pairs rest), and the schedule with fewest crossing frames is
   kept. When two matched pairs still cross, the dearest pair (not pinned by
   anchors) is separated: its source part shrinks and its target part grows
   instead, kept only when that lowers the count. A pair the strain method
   cannot morph (no compatible meshes, or the target not reached) is
   separated too, with the reason. What remains is reported
   (``parts.overlapping_frames``, ``parts.self_crossing_frames``,
   ``parts.fallback_pairs`` in ``metrics.json``, and on the command line),
   never silently emitted.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components
from shapely.geometry.base import BaseGeometry
from shapely.ops import nearest_points, polylabel

from conformorph.geometry.boundary_loop import boundary_loops
from conformorph.geometry.shape_rings import ShapeRings, points_in_shape
from conformorph.geometry.triangulate_shape import triangulate_shape
from conformorph.pipelines.morph2d.compatible_meshes import CompatibleMeshes, morph2d_meshes
from conformorph.pipelines.morph2d.correspondence import corresponding_anchors, working_resolution
from conformorph.pipelines.morph2d.frame_crossings import crossing_frames, frame_polygons
from conformorph.pipelines.morph2d.frame_parts import frame_parts
from conformorph.pipelines.morph2d.inputs import Morph2DInputs
from conformorph.pipelines.morph2d.options import Morph2DOptions
from conformorph.pipelines.morph2d.part_matching import PartMatching, match_parts
from conformorph.pipelines.morph2d.rigid_motion import reference_points
from conformorph.pipelines.morph2d.strain_interpolation import StrainFrames, strain_frames

#: Smallest scale of a part that grows out of or shrinks into a point.
VANISH_SCALE = 1e-3
#: Narrowest room (a fraction of the part's size, the square root of its area) for a
#: part's vanishing point beside the other shape (:func:`_lone_part`): ten specks wide.
FREE_POLE_MARGIN = 10 * VANISH_SCALE
#: Passes of :func:`_rested` (vanishing points moved out of what covers them), each
#: kept only when it lowers the crossing count.
REST_PASSES = 3
#: Growth schedules tried, in order: (start, end) in t of the shrinking, of the growing
#: and (when given; else all of [0, 1]) of the matched pairs' morph.
SCHEDULES: dict[str, tuple[tuple[float, float], ...]] = {
    "together": ((0.0, 1.0), (0.0, 1.0)),
    "shrink_first": ((0.0, 0.5), (0.5, 1.0)),
    "grow_first": ((0.5, 1.0), (0.0, 0.5)),
    "shrink_early": ((0.0, 0.2), (0.8, 1.0)),
    # one after the other: parts shrink while the matched pairs wait at the source, the
    # pairs morph, then parts grow while the pairs rest at the target
    "sequential": ((0.0, 0.2), (0.8, 1.0), (0.2, 0.8)),
}


@dataclass(frozen=True)
class PartPair:
    """One matched pair morphed: its meshes, frames and how its anchors were chosen."""

    meshes: CompatibleMeshes
    run: StrainFrames
    correspondence: dict[str, Any]
    document: dict[str, Any] | None


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
    run = strain_frames(
        meshes, reference_points(inputs.anchors), opts.frames, opts.interp, opts.solver
    )
    return PartPair(meshes, run, chosen.info | {"working_resolution": resolution}, chosen.document)


def _scale(
    times: NDArray[np.float64], span: tuple[float, float], grow: bool
) -> NDArray[np.float64]:
    a, b = span
    u = np.clip((times - a) / (b - a), 0.0, 1.0)
    s = u if grow else 1.0 - u
    return VANISH_SCALE + (1.0 - VANISH_SCALE) * s


def _lone_part(
    shape: ShapeRings, other: BaseGeometry | None = None
) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """A part's own mesh and the point it grows from or shrinks into.

    The point is the pole of inaccessibility of the part less ``other`` (the other
    shape, where the part is a speck at the morph's other end), so that the speck
    rests beside the other shape's parts, not inside one; the part's own pole when
    ``other`` leaves no room ``FREE_POLE_MARGIN`` times the part's size wide.
    """
    V, F = triangulate_shape(shape)
    poly = shapely.Polygon(shape.outer, list(shape.holes))
    size = float(np.sqrt(poly.area))
    c = polylabel(poly, tolerance=1e-3 * size)
    centre = np.array([c.x, c.y])
    pole = None if other is None else _free_pole(poly, other, size)
    if pole is not None:
        centre = pole
    if not points_in_shape(shape, centre[None])[0]:  # pragma: no cover - polylabel is inside
        centre = np.array(poly.representative_point().coords[0])
    return V, F.astype(np.int64), centre


_Lone = dict[
    tuple[str, int], tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], bool]
]


def _best_schedule(
    pairs: list[PartPair | None], keep: list[bool], lone: _Lone, times: NDArray[np.float64]
) -> tuple[tuple[int, int], str, NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """The growth schedule with fewest (overlapping, self-crossing) frames, and every one tried."""
    tried: dict[str, dict[str, Any]] = {}
    best = None
    lone = _grouped(lone)
    for name in SCHEDULES if lone else ("together",):
        kept = [p for p, k in zip(pairs, keep, strict=True) if k and p is not None]
        frames, F = _assemble(kept, lone, times, name)
        tried[name] = crossing_frames(frames, F, times)
        score = (tried[name]["overlapping_frames"], tried[name]["self_crossing_frames"])
        if best is None or score < best[0]:
            best = (score, name, frames, F)
        if score == (0, 0):
            break
    assert best is not None
    return (*best, tried)


def _grouped(lone: _Lone) -> _Lone:
    """Parts that grow (or shrink) close together share one centre: the pole of the largest.

    Parts whose convex hulls meet (letters in a badge's holes, pieces of a cut logo) are
    scaled about one point with one scale, a similarity of the whole group, so they stay
    apart from each other in every frame; each group's centre is its largest part's pole
    of inaccessibility.
    """
    out = dict(lone)
    for grows in (False, True):
        keys = [k for k, v in lone.items() if v[3] is grows]
        if len(keys) < 2:
            continue
        hulls = [shapely.MultiPoint(lone[k][0]).convex_hull for k in keys]
        tree = shapely.STRtree(hulls)
        left, right = tree.query(hulls, predicate="intersects")
        n = len(keys)
        graph = coo_array((np.ones(left.size), (left, right)), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        for g in np.unique(label):
            members = [keys[i] for i in np.flatnonzero(label == g)]
            big = max(members, key=lambda k: hulls[keys.index(k)].area)
            for k in members:
                V, F, _, flag = lone[k]
                out[k] = (V, F, lone[big][2], flag)
    return out


def _rested(
    pairs: list[PartPair | None],
    keep: list[bool],
    lone: _Lone,
    times: NDArray[np.float64],
    schedule: str,
) -> _Lone:
    """Each unpartnered part's vanishing point moved out of what the other parts cover
    while it is a speck (in ``schedule``'s frames): the pole of the part less that
    region, when it leaves room ``FREE_POLE_MARGIN`` times the part's size wide."""
    kept = [p for p, k in zip(pairs, keep, strict=True) if k and p is not None]
    frames, F = _assemble(kept, _grouped(lone), times, schedule)
    start = sum(p.run.frames.shape[1] for p in kept)
    out = dict(lone)
    for key, (V, F_own, _, grows) in lone.items():
        stop = start + V.shape[0]
        own = (F >= start).all(axis=1) & (F < stop).all(axis=1)
        span = SCHEDULES[schedule][1 if grows else 0]
        speck = np.flatnonzero(_scale(times, span, grows) <= VANISH_SCALE)
        start = stop
        if speck.size == 0 or own.all():
            continue
        poly = shapely.Polygon(V[_outer_loop(F_own, V)])
        size = float(np.sqrt(poly.area))
        fp = frame_parts(frames[speck], F[~own], times[speck])
        near = poly.buffer(size)  # only what lies near the part can cover its speck
        others = frame_polygons(frames[speck], fp.loops).ravel()
        others = others[shapely.intersects(others, near)]
        # a part resting still is the same polygon in many frames: once is enough
        _, first = np.unique(shapely.to_wkb(others), return_index=True)
        covered = shapely.union_all(shapely.make_valid(others[first]))
        out[key] = (V, F_own, _free_point(poly, covered, lone[key][2], size), grows)
    return out


def _free_point(
    poly: shapely.Polygon, covered: BaseGeometry, centre: NDArray[np.float64], size: float
) -> NDArray[np.float64]:
    """Where a part of ``size`` vanishes beside ``covered``: the pole of the part less
    ``covered`` when that leaves room ``FREE_POLE_MARGIN * size`` wide, else the point
    nearest ``centre`` twice that far from ``covered`` (beside the part: it then shrinks
    towards it, or grows from it, while moving)."""
    margin = FREE_POLE_MARGIN * size
    pole = _free_pole(poly, covered, size)
    if pole is not None:
        return pole
    here = shapely.Point(centre)
    if covered.is_empty or covered.distance(here) > margin:
        return centre
    away = covered.buffer(2 * margin)
    return np.array(nearest_points(away.boundary, here)[0].coords[0])


def _free_pole(
    poly: shapely.Polygon, covered: BaseGeometry, size: float
) -> NDArray[np.float64] | None:
    """The pole of inaccessibility of the largest piece of ``poly`` less ``covered``, or
    None when no piece leaves room ``FREE_POLE_MARGIN * size`` wide around it."""
    room = [g for g in shapely.get_parts(poly.difference(covered)) if g.area > 0]
    if not room:
        return None
    best = max(room, key=lambda g: g.area)
    c = polylabel(best, tolerance=1e-3 * size)
    return np.array([c.x, c.y]) if best.boundary.distance(c) > FREE_POLE_MARGIN * size else None


def _outer_loop(F: NDArray[np.int64], V: NDArray[np.float64]) -> NDArray[np.int64]:
    """The boundary loop of a one-part mesh that encloses the most area."""
    loops = [np.asarray(lp, dtype=np.int64) for lp in boundary_loops(F)]
    return max(loops, key=lambda lp: abs(float(shapely.Polygon(V[lp]).area)))


def _retimed(
    frames: NDArray[np.float64], times: NDArray[np.float64], span: tuple[float, float]
) -> NDArray[np.float64]:
    """A pair's frames played within ``span`` of t: held at the ends, blended linearly
    between its two nearest frames in between; (len(times), n, 2)."""
    a, b = span
    u = np.clip((times - a) / (b - a), 0.0, 1.0) * (frames.shape[0] - 1)
    lo = np.floor(u).astype(np.int64)
    hi = np.minimum(lo + 1, frames.shape[0] - 1)
    w = (u - lo)[:, None, None]
    return (1.0 - w) * frames[lo] + w * frames[hi]


def _assemble(
    pairs: list[PartPair],
    lone: _Lone,
    times: NDArray[np.float64],
    schedule: str,
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """All parts' frames side by side in one vertex array, faces offset."""
    blocks, faces, offset = [], [], 0
    shrink, grow, *span = SCHEDULES[schedule]
    for p in pairs:
        blocks.append(_retimed(p.run.frames, times, span[0]) if span else p.run.frames)
        faces.append(p.meshes.F + offset)
        offset += p.run.frames.shape[1]
    for V, F, c, grows in lone.values():
        s = _scale(times, grow if grows else shrink, grows)
        blocks.append(c + s[:, None, None] * (V - c)[None])
        faces.append(F + offset)
        offset += V.shape[0]
    return np.concatenate(blocks, axis=1), np.vstack(faces)


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

    Returns
    -------
    PartsMorph
    """
    where = anchor_pins(source, target, anchors, anchor_parts)
    matching = match_parts(source, target, [(int(w[0]), int(w[1])) for w in where])
    pairs, failed = _pairs_morphed(source, target, anchors, where, matching, opts)
    times = np.linspace(0.0, 1.0, opts.frames)  # as strain_frames takes them
    whole = {
        side: shapely.union_all([shapely.Polygon(p.outer, list(p.holes)) for p in parts])
        for side, parts in (("s", source), ("t", target))
    }

    def alone(
        side: str, i: int
    ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], bool]:
        shape, other = (source[i], whole["t"]) if side == "s" else (target[i], whole["s"])
        return (*_lone_part(shape, other), side == "t")

    lone = {("s", int(i)): alone("s", int(i)) for i in matching.unmatched_source}
    lone |= {("t", int(j)): alone("t", int(j)) for j in matching.unmatched_target}
    for k in failed:
        i, j = (int(x) for x in matching.pairs[k])
        lone[("s", i)] = alone("s", i)
        lone[("t", j)] = alone("t", j)
    keep = [k not in failed for k in range(len(pairs))]
    best = _best_schedule(pairs, keep, lone, times)
    pinned = {(int(i), int(j)) for i, j in matching.pinned}
    for k in np.argsort(-matching.cost, kind="stable"):  # dearest pair first
        if best[0] == (0, 0) or sum(keep) <= 1:
            break
        i, j = (int(x) for x in matching.pairs[k])
        if (i, j) in pinned or not keep[k]:
            continue
        # a pair that crosses another: the source part shrinks, the target's grows instead
        extra = {("s", i): alone("s", i), ("t", j): alone("t", j)}
        trial_keep = [x and n != k for n, x in enumerate(keep)]
        trial = _best_schedule(pairs, trial_keep, lone | extra, times)
        if trial[0] < best[0]:
            best, keep, lone = trial, trial_keep, lone | extra
    for _ in range(REST_PASSES):
        if best[0] == (0, 0) or not lone:
            break
        rested = _rested(pairs, keep, lone, times, best[1])
        trial = _best_schedule(pairs, keep, rested, times)
        if not trial[0] < best[0]:
            break
        best, lone = trial, rested
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
        "unmatched": "grow out of / shrink into the part's pole of inaccessibility",
        "schedule": schedule,
        "schedules_tried": tried,
        **tried[schedule],
    }
    return PartsMorph(frames, F, frames[0], frames[-1], times, pairs, matching, info)


def _pairs_morphed(
    source: list[ShapeRings],
    target: list[ShapeRings],
    anchors: NDArray[np.float64],
    where: NDArray[np.int64],
    matching: PartMatching,
    opts: Morph2DOptions,
) -> tuple[list[PartPair | None], dict[int, str]]:
    """Each matched pair morphed; a pair the strain method cannot morph (its meshes cannot
    be built, or it does not reach the target) is None, with the reason, unless anchors
    pinned it (then the error is the user's to see)."""
    pinned = {(int(i), int(j)) for i, j in matching.pinned}
    pairs: list[PartPair | None] = []
    failed: dict[int, str] = {}
    for k, (i, j) in enumerate(matching.pairs):
        mine = (where[:, 0] == i) & (where[:, 1] == j)
        try:
            pair = _pair_morph(source[i], target[j], anchors[mine], opts)
        except (ValueError, ArithmeticError) as exc:
            if (int(i), int(j)) in pinned:
                raise
            pairs.append(None)
            failed[k] = f"{type(exc).__name__}: {exc}"
            continue
        if not pair.run.used["reached_target"] and (int(i), int(j)) not in pinned:
            failed[k] = (
                f"the strain morph did not reach the target (last frame "
                f"{pair.run.used['target_error']:.3g} of its size away)"
            )
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


def with_parts_pace(opts: Morph2DOptions) -> Morph2DOptions:
    """The options a several-part morph runs with: every pair on the same frame times
    (``pace="even"`` re-times each pair differently, so it is not applied)."""
    return replace(opts, pace="strain")
