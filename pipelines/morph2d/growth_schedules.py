"""How parts without a partner grow and shrink beside the matched pairs, with no part
crossing another (steps 3 and 4 of :mod:`conformorph.pipelines.morph2d.part_morph`).

A part without a partner keeps its own mesh and scales about one point (a source part
shrinks into it, a target part grows out of it) down to ``VANISH_SCALE``; parts whose
convex hulls meet scale about one point as a group. The growth schedules
(``SCHEDULES``) time the shrinking, the growing and the matched pairs' morph; the one
with fewest crossing frames is kept (:func:`best_schedule`). When parts still cross,
the points are moved (:func:`settled_schedule`): out of what the other parts cover
while the part is a speck (:func:`_rested`), and, for the schedules in which all
shrinking ends before any growing starts, out of what the shrinking parts sweep and
the shadows of the specks they leave
(:func:`conformorph.pipelines.morph2d.vanishing_points.growth_points`), first group by
group, then with all growing parts as one group and all shrinking parts as one.
"""

from __future__ import annotations

from dataclasses import dataclass
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
from conformorph.pipelines.morph2d.compatible_meshes import CompatibleMeshes
from conformorph.pipelines.morph2d.frame_crossings import crossing_frames, frame_polygons
from conformorph.pipelines.morph2d.frame_parts import frame_parts
from conformorph.pipelines.morph2d.strain_interpolation import StrainFrames
from conformorph.pipelines.morph2d.vanishing_points import growth_points

#: Smallest scale of a part that grows out of or shrinks into a point.
VANISH_SCALE = 1e-3
#: Narrowest room (a fraction of the part's size, the square root of its area) for a
#: part's vanishing point beside the other shape (:func:`lone_part`): ten specks wide.
FREE_POLE_MARGIN = 10 * VANISH_SCALE
#: Gap between all parts and the points of :func:`_aside`, a fraction of the parts'
#: extent: twenty times a speck's reach.
ASIDE_GAP = 20 * VANISH_SCALE
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


#: The schedules in which every part shrinks before any part grows.
SEPARATED_SCHEDULES = tuple(n for n, s in SCHEDULES.items() if s[0][1] <= s[1][0])


@dataclass(frozen=True)
class PartPair:
    """One matched pair morphed: its meshes, frames and how its anchors were chosen."""

    meshes: CompatibleMeshes
    run: StrainFrames
    correspondence: dict[str, Any]
    document: dict[str, Any] | None


def _scale(
    times: NDArray[np.float64], span: tuple[float, float], grow: bool
) -> NDArray[np.float64]:
    a, b = span
    u = np.clip((times - a) / (b - a), 0.0, 1.0)
    s = u if grow else 1.0 - u
    return VANISH_SCALE + (1.0 - VANISH_SCALE) * s


def lone_part(
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


#: Parts without a partner, by ``("s" | "t", part index)``: their own mesh (vertices,
#: triangles), the point they scale about, and whether they grow (target side).
LonePart = tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], bool]
LoneParts = dict[tuple[str, int], LonePart]


def best_schedule(
    pairs: list[PartPair | None], keep: list[bool], lone: LoneParts, times: NDArray[np.float64]
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


def settled_schedule(
    pairs: list[PartPair | None], keep: list[bool], lone: LoneParts, times: NDArray[np.float64]
) -> tuple[tuple[int, int], str, NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """The best schedule (:func:`best_schedule`) after up to ``REST_PASSES`` passes of
    :func:`_rested` and then the growth points of :func:`_placed_growth`, each kept only
    when it lowers the crossing count."""
    best = best_schedule(pairs, keep, lone, times)
    for _ in range(REST_PASSES):
        if best[0] == (0, 0) or not lone:
            break
        rested = _rested(pairs, keep, lone, times, best[1])
        trial = best_schedule(pairs, keep, rested, times)
        if not trial[0] < best[0]:
            break
        best, lone = trial, rested
    if best[0] != (0, 0) and lone:
        tries = [best[1], *(n for n in SEPARATED_SCHEDULES if n != best[1])]
        for schedule, merged in [(n, m) for m in (False, True) for n in tries]:
            placed = _placed_growth(pairs, keep, lone, times, schedule, merged)
            if placed is None:
                continue
            trial = best_schedule(pairs, keep, placed, times)
            if trial[0] < best[0]:
                best, lone = trial, placed
            if best[0] == (0, 0):
                break
    if best[0] != (0, 0) and lone:
        trial = best_schedule(pairs, keep, _aside(pairs, keep, lone), times)
        if trial[0] < best[0]:
            best = trial
    return best


def _aside(pairs: list[PartPair | None], keep: list[bool], lone: LoneParts) -> LoneParts:
    """Every shrinking part's point just left of everything, every growing part's just right.

    The last resort of :func:`settled_schedule`. Every shrinking part then scales about
    one point ``L`` and every growing part about one point ``R``, so each side is a
    similarity of itself in every frame and its own parts never meet. In a schedule
    where all shrinking ends before any growing starts (``SEPARATED_SCHEDULES``), the
    two sides never meet either, whatever their shapes: a shrinking part stays in the
    convex hull of itself and ``L``, left of the x = max of all parts, while the growing
    parts are specks at ``R``, ``ASIDE_GAP`` of the extent beyond it (a speck reaches
    ``VANISH_SCALE`` of the extent from its point); and mirrored while they grow. So a
    shape that dissolves entirely is clean in those schedules; with matched pairs still
    morphing the result is only scored, like every other trial.
    """
    kept = [p.run.frames.reshape(-1, 2) for p, k in zip(pairs, keep, strict=True) if k and p]
    points = np.vstack([v[0] for v in lone.values()] + kept)
    lo, hi = points.min(axis=0), points.max(axis=0)
    gap = ASIDE_GAP * float((hi - lo).max())
    y = 0.5 * (lo[1] + hi[1])
    left, right = np.array([lo[0] - gap, y]), np.array([hi[0] + gap, y])
    return {k: (V, F, right if grows else left, grows) for k, (V, F, _, grows) in lone.items()}


def _placed_growth(
    pairs: list[PartPair | None],
    keep: list[bool],
    lone: LoneParts,
    times: NDArray[np.float64],
    schedule: str,
    merged: bool = False,
) -> LoneParts | None:
    """The growing groups' points chosen by :func:`growth_points` for ``schedule`` (one in
    which all shrinking ends before any growing starts), or None when it is not such a
    schedule or no group moves. ``merged``: all shrinking parts shrink into one point
    (the largest one's) and all growing parts grow out of one, each side then a
    similarity of itself whose parts never meet."""
    shrink, grow, *_ = SCHEDULES[schedule]
    if shrink[1] > grow[0]:
        return None
    lone = _grouped(lone)
    groups = _groups(lone)
    if merged:
        groups = [
            sorted(
                (k for g in groups for k in g if lone[k][3] is side),
                key=lambda k: -shapely.MultiPoint(lone[k][0]).convex_hull.area,
            )
            for side in (False, True)
        ]
        groups = [g for g in groups if g]
        lone = {k: (*lone[k][:2], lone[g[0]][2], lone[k][3]) for g in groups for k in g}

    def polys(members: list[tuple[str, int]]) -> list[shapely.Polygon]:
        return [shapely.Polygon(lone[k][0][_outer_loop(lone[k][1], lone[k][0])]) for k in members]

    growing = [g for g in groups if lone[g[0]][3]]
    shrinking = [(polys(g), lone[g[0]][2]) for g in groups if not lone[g[0]][3]]
    kept = [p for p, k in zip(pairs, keep, strict=True) if k and p is not None]
    covered = shapely.Polygon()
    if kept:
        frames, F = _assemble(kept, lone, times, schedule)
        end = sum(p.run.frames.shape[1] for p in kept)
        mine = (F < end).all(axis=1)
        waiting = np.flatnonzero(_scale(times, grow, True) <= VANISH_SCALE)
        covered = shapely.union_all(
            shapely.make_valid(_polygons_at(frames, F[mine], waiting, times))
        )
    grown = [polys(g) for g in growing]
    sizes = [np.sqrt(sum(p.area for p in g)) for g in grown]
    points = growth_points(grown, shrinking, covered, FREE_POLE_MARGIN * min(sizes, default=1.0))
    out = dict(lone)
    for members, point in zip(growing, points, strict=True):
        if point is not None:
            for k in members:
                V, F_own, _, flag = lone[k]
                out[k] = (V, F_own, point, flag)
    return None if all(p is None for p in points) else out


def _groups(lone: LoneParts) -> list[list[tuple[str, int]]]:
    """The parts that grow (or shrink) as one: connected by convex hulls that meet,
    the largest (by hull area) first; every lone part is in one group."""
    out = []
    for grows in (False, True):
        keys = [k for k, v in lone.items() if v[3] is grows]
        if not keys:
            continue
        hulls = [shapely.MultiPoint(lone[k][0]).convex_hull for k in keys]
        tree = shapely.STRtree(hulls)
        left, right = tree.query(hulls, predicate="intersects")
        n = len(keys)
        graph = coo_array((np.ones(left.size), (left, right)), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        for g in np.unique(label):
            members = np.flatnonzero(label == g)
            members = members[np.argsort([-hulls[i].area for i in members], kind="stable")]
            out.append([keys[i] for i in members])
    return out


def _grouped(lone: LoneParts) -> LoneParts:
    """Parts that grow (or shrink) close together share one centre: the pole of the largest.

    Parts whose convex hulls meet (letters in a badge's holes, pieces of a cut logo) are
    scaled about one point with one scale, a similarity of the whole group, so they stay
    apart from each other in every frame; each group's centre is its largest part's pole
    of inaccessibility.
    """
    out = dict(lone)
    for members in _groups(lone):
        for k in members:
            V, F, _, flag = lone[k]
            out[k] = (V, F, lone[members[0]][2], flag)
    return out


def _rested(
    pairs: list[PartPair | None],
    keep: list[bool],
    lone: LoneParts,
    times: NDArray[np.float64],
    schedule: str,
) -> LoneParts:
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
        near = poly.buffer(size)  # only what lies near the part can cover its speck
        others = _polygons_at(frames, F[~own], speck, times)
        others = others[shapely.intersects(others, near)]
        # a part resting still is the same polygon in many frames: once is enough
        _, first = np.unique(shapely.to_wkb(others), return_index=True)
        covered = shapely.union_all(shapely.make_valid(others[first]))
        out[key] = (V, F_own, _free_point(poly, covered, lone[key][2], size), grows)
    return out


def _polygons_at(
    frames: NDArray[np.float64],
    faces: NDArray[np.int64],
    at: NDArray[np.int64],
    times: NDArray[np.float64],
) -> Any:
    """Every part that ``faces`` make, as a shapely polygon, in each of the frames ``at``;
    a flat object array."""
    fp = frame_parts(frames[at], faces, times[at])
    return frame_polygons(frames[at], fp.loops).ravel()


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
    lone: LoneParts,
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
