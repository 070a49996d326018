"""A whole SVG file read as a shape of several parts (svgelements behind a safe pre-check).

Reading goes in three steps:

1. :func:`svg_precheck`, a streaming pass of the standard library's XML parser
   over the text, refuses what a hostile file could use before svgelements
   sees it: any entity declaration (``<!ENTITY``: internal ones expand, the
   "billion laughs"; external ones name files), nesting deeper than
   ``MAX_XML_DEPTH``, more than ``MAX_SVG_ELEMENTS`` elements, a ``<use>``
   of something that itself holds a ``<use>`` (expansion that grows
   exponentially), and path data over the point limit or malformed
   (:func:`conformorph.pipelines.svg_path.check_path_data`, with positions).
2. svgelements (MIT) parses the document: ``viewBox`` and units, nested
   ``transform``s, basic shapes (``rect`` with ``rx``/``ry``, ``circle``,
   ``ellipse``, ``line``, ``polyline``, ``polygon``), ``<use>``, CSS ``style``
   sheets and attributes, presentation attributes; elements with
   ``display: none`` or ``visibility: hidden`` and those inside ``<defs>``,
   ``<clipPath>``, ``<mask>`` and ``<symbol>`` paint nothing.
3. Each element's painted region is its fill (by its ``fill-rule``) united
   with its stroke's outline (:mod:`conformorph.pipelines.svg_regions`); the
   shape is the union of all elements' regions (colours are not read: the
   silhouette morphs). Its polygons are the parts, each an outer ring and
   holes, y flipped to y up.

A file with more than ``max_points`` vertices as written (one per segment
end, a curve counting one) is refused, as before curves were read adaptively.
Curves and round joins are flattened to ``SVG_FLATTEN_RTOL`` times the
drawing's diagonal. When the rings then have more than ``max_points`` points
(points the author did not write) the region is simplified (Douglas–Peucker, tolerance doubled until it fits,
at most ``SIMPLIFY_ROUNDS`` times) and a note says so; past that the file is
refused as too large.
"""

from __future__ import annotations

import io
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
import svgelements as se
from numpy.typing import NDArray

from conformorph.geometry.shape_rings import ShapeError
from conformorph.geometry.tolerances import SVG_FLATTEN_RTOL
from conformorph.pipelines.svg_path import (
    TOKEN_ALLOWANCE,
    TOKENS_PER_POINT,
    ShapeTooLargeError,
    check_path_data,
    path_polylines,
    written_points,
)
from conformorph.pipelines.svg_regions import (
    fill_region,
    region_parts,
    separate_touching,
    stroke_region,
)

#: Deepest element nesting read in an SVG file.
MAX_XML_DEPTH = 256
#: Most elements read in an SVG file.
MAX_SVG_ELEMENTS = 10_000
#: Rounds of simplification (tolerance doubled each) tried before a shape over
#: ``max_points`` is refused.
SIMPLIFY_ROUNDS = 8
#: Parts and holes smaller than this fraction of the drawing's painted area are
#: dropped (slivers of the region algebra; reported).
MIN_PART_AREA_FRACTION = 1e-6
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_CONTAINERS = frozenset({"defs", "clipPath", "mask", "symbol", "pattern", "marker"})


@dataclass(frozen=True)
class SvgShape:
    """The parts an SVG file paints.

    Attributes
    ----------
    parts : list of list of (k, 2) float64
        Per part (largest area first), its outer ring then its holes, y up,
        closing point not repeated (orientation not yet checked).
    notes : tuple of str
        What reading did beyond parsing: strokes outlined, fill rules
        applied, elements skipped, slivers dropped, simplification.
    stroked : int
        Elements whose stroke was outlined into the region.
    """

    parts: list[list[NDArray[np.float64]]]
    notes: tuple[str, ...]
    stroked: int


def _local(tag: str) -> str:
    return tag.split("}")[-1]


def svg_precheck(text: str, max_points: int) -> None:
    """Refuse a hostile or over-large SVG document before it is parsed (see the module notes).

    Parameters
    ----------
    text : str
    max_points : int
        The point limit; path data and point lists may hold at most
        ``TOKENS_PER_POINT`` × ``max_points`` + ``TOKEN_ALLOWANCE`` tokens.

    Raises
    ------
    ShapeError
        Entity declarations, a nested ``<use>``, invalid XML, malformed path data.
    ShapeTooLargeError
        Too deep, too many elements, too many path tokens.
    """
    if "<!ENTITY" in text.upper():
        raise ShapeError(
            "SVG file declares entities (<!ENTITY ...>); such declarations are not read "
            "(remove the <!DOCTYPE ...> block)"
        )
    parser: ET.XMLPullParser = ET.XMLPullParser(events=("start", "end"))
    budget = TOKENS_PER_POINT * max_points + TOKEN_ALLOWANCE
    written = 0  # vertices as written, a lower bound known before parsing
    stack: list[list[Any]] = []  # [id, holds a <use>]
    holds_use: dict[str, bool] = {}
    hrefs: list[str] = []
    count = 0
    try:
        for k in range(0, max(len(text), 1), 1 << 16):
            parser.feed(text[k : k + (1 << 16)])
            for item in parser.read_events():
                event, el = item[0], item[-1]
                if not isinstance(el, ET.Element):
                    continue
                if event == "end":
                    el_id, has_use = stack.pop()
                    if el_id is not None:
                        holds_use[el_id] = has_use
                    if stack and has_use:
                        stack[-1][1] = True
                    el.clear()  # keep memory flat
                    continue
                count += 1
                if len(stack) + 1 > MAX_XML_DEPTH:
                    raise ShapeTooLargeError(
                        f"SVG file nests elements more than {MAX_XML_DEPTH} levels deep"
                    )
                if count > MAX_SVG_ELEMENTS:
                    raise ShapeTooLargeError(f"SVG file has more than {MAX_SVG_ELEMENTS} elements")
                tag = _local(el.tag)
                stack.append([el.get("id"), tag == "use"])
                if tag == "use":
                    href = el.get("href") or el.get("{http://www.w3.org/1999/xlink}href") or ""
                    hrefs.append(href.lstrip("#"))
                tokens, vertices = _tokens(el, tag, budget)
                budget -= tokens
                written += vertices
                if written > max_points:
                    raise ShapeTooLargeError(
                        f"SVG file has {written} points as written, more than {max_points} "
                        f"(the limit per shape), by its element {count}"
                    )
        parser.close()
    except ET.ParseError as exc:
        raise ShapeError(f"SVG file is not valid XML: {exc}") from exc
    for href in hrefs:
        if holds_use.get(href):
            raise ShapeError(
                f"SVG file uses '#{href}', which itself holds a <use>; nested <use> "
                "elements are not read (their copies can multiply without bound)"
            )


def _tokens(el: ET.Element, tag: str, budget: int) -> tuple[int, int]:
    """Tokens and vertices of an element's geometry (path data, point lists), checked;
    refused past ``budget`` tokens."""
    if tag == "path":
        return check_path_data(el.get("d", ""), max(budget, 0))
    if tag in ("polygon", "polyline"):
        pts = el.get("points", "")
        n = sum(1 for _ in zip(range(budget + 1), _NUMBER.finditer(pts), strict=False))
        if n > budget:
            raise ShapeTooLargeError(
                "SVG point lists have more numbers than the point limit allows"
            )
        return n, n // 2
    return 1, 0


def _painted(shape: Any) -> bool:
    v = shape.values
    return v.get("visibility", "visible") not in ("hidden", "collapse")


def _paint(color: Any) -> bool:
    return color is not None and color.value is not None


def _element_paths(doc: Any) -> list[tuple[Any, Any, float]]:
    """Each painted shape element with its path and stroke width in the root's user units.

    svgelements maps everything into the viewport (the root's ``viewBox``
    scaled to its ``width`` and ``height``); the inverse of that one map brings
    it back to the coordinates the file's path data are written in, the ones
    an anchors file names.
    """
    vt = se.Matrix(doc.viewbox_transform) if getattr(doc, "viewbox_transform", "") else se.Matrix()
    back = ~vt
    scale = math.sqrt(abs(vt.a * vt.d - vt.b * vt.c)) or 1.0
    out = []
    for e in doc.elements():
        if not isinstance(e, se.Shape) or not _painted(e):
            continue
        if not (_paint(e.fill) or _paint(e.stroke)):
            continue
        path = se.Path(e) * back
        path.reify()
        width = float(e.implicit_stroke_width or 0.0) / scale if _paint(e.stroke) else 0.0
        out.append((e, path, width))
    return out


def _drawing_size(items: list[tuple[Any, Any, float]]) -> float:
    boxes = [b for _, p, _ in items if (b := p.bbox()) is not None]
    if not boxes:
        return 1.0
    B = np.array(boxes, dtype=np.float64)
    size = math.hypot(B[:, 2].max() - B[:, 0].min(), B[:, 3].max() - B[:, 1].min())
    return size if math.isfinite(size) and size > 0 else 1.0


def read_svg_shape(text: str, *, max_points: int) -> SvgShape:
    """The parts an SVG document paints.

    Parameters
    ----------
    text : str
        The document.
    max_points : int
        Most points over all rings of all parts.

    Returns
    -------
    SvgShape

    Raises
    ------
    ShapeError, SvgPathError, ShapeTooLargeError
        As :func:`svg_precheck`; a document that paints nothing; a part
        count or point count over the limits.
    """
    svg_precheck(text, max_points)
    try:
        doc = se.SVG.parse(io.StringIO(text), reify=True)
    except (ValueError, IndexError, KeyError, TypeError, ET.ParseError) as exc:
        raise ShapeError(f"SVG file cannot be read ({type(exc).__name__}: {exc})"[:300]) from exc
    items = _element_paths(doc)
    if not items:
        raise ShapeError("SVG file paints nothing: no <path> or basic shape with a fill or stroke")
    written = sum(written_points(p) for _, p, _ in items)
    if written > max_points:
        raise ShapeTooLargeError(
            f"SVG file has {written} points as written, more than {max_points} "
            "(the limit per shape)"
        )
    size = _drawing_size(items)
    tol = SVG_FLATTEN_RTOL * size
    notes: list[str] = []
    regions, stroked, rules = [], 0, set()
    for e, path, width in items:
        lines = path_polylines(path, tol)
        if _paint(e.fill):
            rule = str(e.values.get("fill-rule", "nonzero")).strip()
            rules.add(rule)
            regions.append(fill_region(lines, rule))
        if width > 0:
            stroked += 1
            regions.append(
                stroke_region(
                    lines,
                    width,
                    cap=str(e.values.get("stroke-linecap", "butt")).strip(),
                    join=str(e.values.get("stroke-linejoin", "miter")).strip(),
                    miterlimit=_float(e.values.get("stroke-miterlimit"), 4.0),
                    tol=tol,
                )
            )
    region = shapely.union_all(regions)
    if stroked:
        notes.append(f"{stroked} stroked element(s) outlined at their stroke width, caps and joins")
    if rules - {"nonzero"}:
        notes.append(f"fill rules applied: {', '.join(sorted(rules))}")
    return SvgShape(_fit(region, tol, max_points, notes), tuple(notes), stroked)


def _float(value: Any, default: float) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return default
    return x if math.isfinite(x) else default


def _untouched(region: Any, tol: float, notes: list[str]) -> Any:
    """The region with touching rings pulled apart by a quarter of the tolerance (noted)."""
    region, repaired = separate_touching(region, 0.25 * tol)
    if repaired:
        notes.append(
            f"{repaired} part(s) whose outline and holes touched, or that touched another "
            f"part, eroded by {0.25 * tol:.3g} to separate them"
        )
    return region


def _fit(
    region: Any, tol: float, max_points: int, notes: list[str]
) -> list[list[NDArray[np.float64]]]:
    """The region's parts (y up), simplified when over ``max_points``."""
    if region.is_empty or not region.area > 0:
        raise ShapeError("SVG file paints no area (its fills and strokes are all empty)")
    # points within 1e-3 of the tolerance of their neighbours' chord add nothing but
    # slivers to the meshes (a rounded rect's straight side meets its corner arcs there)
    region = _untouched(shapely.simplify(region, 1e-3 * tol, preserve_topology=True), tol, notes)
    min_area = MIN_PART_AREA_FRACTION * float(region.area)
    total = len(list(shapely.get_parts(region)))
    parts = region_parts(region, min_area=min_area)
    if len(parts) < total:
        notes.append(f"{total - len(parts)} sliver part(s) under {min_area:.3g} in area dropped")
    step = tol
    for _ in range(SIMPLIFY_ROUNDS):
        n = sum(r.shape[0] for rings in parts for r in rings)
        if n <= max_points:
            return [[r * [1.0, -1.0] for r in rings] for rings in parts]
        step *= 2
        simpler = _untouched(shapely.simplify(region, step, preserve_topology=True), tol, notes)
        parts = region_parts(simpler, min_area=min_area)
        notes.append(f"{n} points over the limit of {max_points}: outline simplified to {step:.3g}")
    n = sum(r.shape[0] for rings in parts for r in rings)
    if n <= max_points:
        return [[r * [1.0, -1.0] for r in rings] for rings in parts]
    raise ShapeTooLargeError(
        f"SVG shape has {n} points after simplifying, more than {max_points} (the limit per shape)"
    )
