"""Where parts that grow out of a point wait, so that nothing shrinking passes over them.

A part scaled about a point ``c`` by ``s`` in [0, 1] covers, over the whole scaling,
its *sweep*: every point ``c + s (x - c)`` with ``x`` in the part. That is the part
together with the triangles ``(c, a, b)`` over its boundary edges ``ab`` (a point
between ``c`` and the part lies on a segment from ``c`` to a boundary point). A speck
waiting at ``q`` while the part shrinks is passed over exactly when ``q`` lies in that
sweep, so checking frames finds only the frames that happen to fall inside it.

The reverse holds for a part growing out of ``q`` over a speck resting at ``c``: the
speck is passed over when ``c = q + s (g - q)`` for some ``g`` in the part, i.e. when
``q`` lies on a ray from a point of the part through ``c``, beyond ``c``. Those ``q``
form the sweep about ``c`` of the part reflected through ``c`` and enlarged
(:func:`shadow`), so both conditions are regions to stay out of, found with shapely.

:func:`growth_points` uses both for the schedules in which every part shrinks before any
part grows (``shrink_first``, ``shrink_early``, ``sequential``): each group of parts that
grows as one waits at a point outside what the shrinking parts sweep, what the matched
pairs cover while it waits, and the shadows of the specks the shrinking parts leave;
inside its largest part when that leaves room, else at the nearest free point around
it (it then moves into place while it grows).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry.base import BaseGeometry
from shapely.ops import polylabel

#: How far a reflected part reaches (:func:`shadow`), in units of the scene's size over
#: the speck's distance from the part: beyond the scene, where no point is placed.
SHADOW_REACH = 4.0


def sweep(poly: shapely.Polygon, centre: NDArray[np.float64]) -> BaseGeometry:
    """Region covered by ``poly`` scaled about ``centre`` by every factor in [0, 1].

    Parameters
    ----------
    poly : shapely.Polygon
        The part (its outer ring bounds the sweep; holes are covered too).
    centre : (2,) float64

    Returns
    -------
    shapely geometry
        ``poly`` together with the triangles ``(centre, a, b)`` over the edges ``ab``
        of its outer ring.
    """
    ring = np.asarray(poly.exterior.coords)[:-1]
    a, b = ring, np.roll(ring, -1, axis=0)
    tri = np.stack([np.broadcast_to(centre, a.shape), a, b, np.broadcast_to(centre, a.shape)], 1)
    cross = (a[:, 0] - centre[0]) * (b[:, 1] - centre[1]) - (a[:, 1] - centre[1]) * (
        b[:, 0] - centre[0]
    )
    tri = tri[np.abs(cross) > 0]  # edges seen edge-on cover nothing the others miss
    fan = shapely.polygons(tri)
    return shapely.union_all(np.r_[fan, [shapely.Polygon(ring)]])


def shadow(poly: shapely.Polygon, speck: NDArray[np.float64], reach: float) -> BaseGeometry:
    """Centres about which ``poly``, growing from nothing, would pass over ``speck``.

    Parameters
    ----------
    poly : shapely.Polygon
        The part at its full size (``speck`` outside it).
    speck : (2,) float64
    reach : float
        How far the region is followed from ``speck`` (the scene's size is enough).

    Returns
    -------
    shapely geometry
        The rays from the points of ``poly`` through ``speck``, beyond it, up to
        ``reach``: the sweep about ``speck`` of ``poly`` reflected through it and
        enlarged.
    """
    d = max(float(poly.distance(shapely.Point(speck))), 1e-300)
    grow = min(SHADOW_REACH * reach / d, 1e6)
    mirrored = shapely.affinity.scale(poly, -grow, -grow, origin=tuple(speck))
    return sweep(mirrored, speck)


def free_point(
    wanted: shapely.Polygon, avoid: BaseGeometry, scene: shapely.Polygon, margin: float
) -> NDArray[np.float64] | None:
    """A point at least ``margin`` from ``avoid``: in ``wanted`` when it has room, else in
    the piece of ``scene`` outside ``avoid`` nearest to ``wanted``; None when none has room.

    Parameters
    ----------
    wanted : shapely.Polygon
        Where the point should be (the group's largest part).
    avoid : shapely geometry
    scene : shapely.Polygon
        Where the point may be at all (a box about both shapes).
    margin : float
    """
    room = avoid.buffer(margin)
    for region in (wanted, scene):
        pieces = [g for g in shapely.get_parts(region.difference(room)) if g.area > 0]
        pieces.sort(key=lambda g: (g.distance(wanted), -g.area))
        for piece in pieces:
            c = polylabel(piece, tolerance=max(margin, 1e-12))
            if not room.contains(c):
                return np.array([c.x, c.y])
    return None


def growth_points(
    growing: Sequence[Sequence[shapely.Polygon]],
    shrinking: Sequence[tuple[Sequence[shapely.Polygon], NDArray[np.float64]]],
    covered: BaseGeometry,
    margin: float,
) -> list[NDArray[np.float64] | None]:
    """A waiting point for each group of growing parts (see the module notes).

    Parameters
    ----------
    growing : sequence of sequence of shapely.Polygon
        Each group's parts at full size, its largest first (the group grows about one point).
    shrinking : sequence of (sequence of shapely.Polygon, (2,) float64)
        Each shrinking group's parts and the point it shrinks into (where its speck rests
        while the others grow).
    covered : shapely geometry
        What the matched pairs cover while the growing parts wait.
    margin : float
        The clearance kept from all of that (a few specks' widths).

    Returns
    -------
    list of (2,) float64 or None
        Per group; None where no point is free (the caller keeps its own).
    """
    everything = [p for g in growing for p in g] + [p for g, _ in shrinking for p in g]
    box = shapely.box(*shapely.union_all(everything).bounds)
    size = float(np.sqrt(box.area))
    scene = box.buffer(0.5 * size, join_style="mitre")
    swept = shapely.union_all([sweep(p, c) for g, c in shrinking for p in g] + [covered])
    out: list[NDArray[np.float64] | None] = []
    taken: list[BaseGeometry] = []
    for group in growing:
        if any(p.buffer(margin).contains(shapely.Point(c)) for _, c in shrinking for p in group):
            out.append(None)  # a speck rests inside the grown part: no centre helps
            continue
        shadows = [shadow(p, c, size) for _, c in shrinking for p in group]
        point = free_point(group[0], shapely.union_all([swept, *shadows, *taken]), scene, margin)
        out.append(point)
        if point is not None:
            taken.append(shapely.Point(point).buffer(margin))
    return out
