"""The region an SVG element paints: its fill by the fill rule, its stroke's outline (shapely).

* Fill: SVG 2 §13.4.2. The sub-paths (each closed, as a fill closes them) cut
  the plane into faces (:func:`shapely.node` then :func:`shapely.polygonize`);
  a face is painted when the winding number of an interior point
  (:func:`conformorph.geometry.shape_rings.winding_numbers`) is non-zero
  (``nonzero``) or odd (``evenodd``). Computing the winding number, rather
  than guessing holes from nesting, gets self-crossing outlines (a pentagram:
  its centre is painted under ``nonzero``, empty under ``evenodd``) and
  same-direction concentric rings (a ring, or a filled disk) right.
* Stroke: SVG 2 §11.4; shapely's buffer of each sub-path by half the stroke
  width with the element's ``stroke-linecap`` (butt, round, square) and
  ``stroke-linejoin`` (miter, round, bevel; ``stroke-miterlimit``), a closed
  sub-path joined at its start. Round caps and joins are polygons whose chords
  stay within the flattening tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry.base import BaseGeometry

from conformorph.geometry.shape_rings import winding_numbers
from conformorph.pipelines.svg_path import Polyline

#: shapely's names of SVG's stroke-linecap and stroke-linejoin values.
_CAPS = {"butt": "flat", "round": "round", "square": "square"}
_JOINS = {
    "miter": "mitre",
    "miter-clip": "mitre",
    "arcs": "round",
    "round": "round",
    "bevel": "bevel",
}


def fill_region(polylines: Sequence[Polyline], rule: str) -> BaseGeometry:
    """The region a fill paints.

    Parameters
    ----------
    polylines : sequence of Polyline
        The element's flattened sub-paths (SVG coordinates); each is closed
        for filling; those with fewer than 3 points paint nothing.
    rule : {"nonzero", "evenodd"}
        SVG's ``fill-rule`` (anything else reads as the default, nonzero).

    Returns
    -------
    shapely geometry
        A (Multi)Polygon, possibly empty.
    """
    rings = [p.points for p in polylines if p.points.shape[0] >= 3]
    if not rings:
        return shapely.Polygon()
    lines = shapely.MultiLineString([np.vstack([r, r[:1]]) for r in rings])
    faces = list(shapely.get_parts(shapely.polygonize(shapely.get_parts(shapely.node(lines)))))
    faces = [f for f in faces if f.area > 0]
    if not faces:
        return shapely.Polygon()
    probes = np.array([[p.x, p.y] for p in (f.point_on_surface() for f in faces)])
    w = winding_numbers(rings, probes)
    keep = (w % 2 == 1) if rule == "evenodd" else (w != 0)
    return shapely.union_all([f for f, k in zip(faces, keep, strict=True) if k])


def round_segments(radius: float, tol: float) -> int:
    """Segments per quarter circle so that a round cap or join of ``radius`` stays within ``tol``.

    Parameters
    ----------
    radius, tol : float

    Returns
    -------
    int
        In [2, 64].
    """
    if radius <= 0 or tol <= 0:
        return 2
    half = math.acos(max(-1.0, 1.0 - tol / radius))
    return int(min(max(math.ceil((math.pi / 2) / (2 * half)) if half > 0 else 64, 2), 64))


def stroke_region(
    polylines: Sequence[Polyline],
    width: float,
    *,
    cap: str = "butt",
    join: str = "miter",
    miterlimit: float = 4.0,
    tol: float,
) -> BaseGeometry:
    """The region a stroke paints: each sub-path buffered by half the stroke width.

    Parameters
    ----------
    polylines : sequence of Polyline
        Flattened sub-paths; closed ones are joined at their start, open ones
        end in caps.
    width : float
        Stroke width in the polylines' units (> 0).
    cap : {"butt", "round", "square"}
    join : {"miter", "round", "bevel"}
    miterlimit : float
        SVG's ratio of miter length to stroke width beyond which a miter
        becomes a bevel (shapely's ``mitre_limit`` is the same ratio).
    tol : float
        Chord tolerance of round caps and joins.

    Returns
    -------
    shapely geometry
        A (Multi)Polygon, possibly empty; a zero-length sub-path with round or
        square caps paints a dot, as SVG says.
    """
    if not width > 0:
        return shapely.Polygon()
    r = 0.5 * width
    kw = {
        "cap_style": _CAPS.get(cap, "flat"),
        "join_style": _JOINS.get(join, "mitre"),
        "mitre_limit": max(float(miterlimit), 1.0),
        "quad_segs": round_segments(r, tol),
    }
    pieces = []
    for p in polylines:
        pts = p.points
        if p.closed and pts.shape[0] >= 3:
            geom: BaseGeometry = shapely.LinearRing(pts)
        elif pts.shape[0] >= 2:
            geom = shapely.LineString(pts)
        else:
            geom = shapely.Point(pts[0])
            if cap == "butt":
                continue
        pieces.append(geom.buffer(r, **kw))  # type: ignore[arg-type]
    return shapely.union_all(pieces) if pieces else shapely.Polygon()


def region_parts(region: BaseGeometry, *, min_area: float) -> list[list[NDArray[np.float64]]]:
    """The polygons of a region as lists of rings, largest first.

    Parameters
    ----------
    region : shapely geometry
    min_area : float
        Polygons and holes smaller than this are dropped (slivers left by
        the region algebra's rounding).

    Returns
    -------
    list of list of (k, 2) float64
        Per polygon, the exterior then the holes, closing point dropped, in
        the region's coordinates.
    """
    polys = [g for g in shapely.get_parts(region) if isinstance(g, shapely.Polygon)]
    polys = sorted((g for g in polys if g.area >= min_area), key=lambda g: -g.area)
    out = []
    for g in polys:
        rings = [np.asarray(g.exterior.coords, dtype=np.float64)[:-1]]
        for h in g.interiors:
            hp = shapely.Polygon(h)
            if hp.area >= min_area:
                rings.append(np.asarray(h.coords, dtype=np.float64)[:-1])
        out.append(rings)
    return out


def _rings_touch(poly: shapely.Polygon) -> bool:
    """Whether a polygon's rings meet each other or themselves (valid in shapely, whose
    polygons may pinch; not a shape the morph's rings can describe)."""
    rings = [poly.exterior, *poly.interiors]
    if not all(r.is_simple for r in rings):
        return True
    if len(rings) < 2:
        return False
    tree = shapely.STRtree(rings)
    left, right = tree.query(rings, predicate="intersects")
    return bool(np.any(left < right))


def separate_touching(region: BaseGeometry, eps: float) -> tuple[BaseGeometry, int]:
    """Pull apart rings that touch: each polygon whose rings meet, or that meets another
    polygon of the region, is eroded by ``eps``.

    A hole that touches its outline at a point (a region pinched there, as the
    union of strokes often is) is opened into a notch or separated by ``eps``;
    two parts that touch at a point (a logo's pieces drawn corner to corner) are
    parted by ``eps``, so that no frame shows them meeting; the area changes by
    about ``eps`` times the perimeter.

    Parameters
    ----------
    region : shapely geometry
    eps : float
        Erosion distance (> 0), mitred joins so that corners stay sharp.

    Returns
    -------
    region : shapely geometry
    repaired : int
        Polygons eroded.
    """
    parts = list(shapely.get_parts(region))
    tree = shapely.STRtree(parts)
    left, right = tree.query(parts, predicate="intersects")
    # parts of a union meet only where they touch (at points: a valid MultiPolygon)
    touching = set(left[left < right].tolist()) | set(right[left < right].tolist())
    out, repaired = [], 0
    for k, g in enumerate(parts):
        if isinstance(g, shapely.Polygon) and (k in touching or _rings_touch(g)):
            g = g.buffer(-eps, join_style="mitre")
            repaired += 1
        out.append(g)
    return (shapely.union_all(out) if repaired else region), repaired
