"""Reading 2D shapes (JSON rings or SVG path data) and anchor files.

* Shape JSON: ``{"rings": [outer, hole, ...]}``, each ring a list of
  ``[x, y]`` (y up), the first point not repeated (a repeat is dropped later).
* SVG: every ``<path d="...">`` of the file, or a bare path-data string;
  each closed sub-path is a ring, the one enclosing the largest area is the
  outer boundary. SVG's y axis points down, so y is negated. Straight
  commands (M, L, H, V, Z) are exact; Bézier curves (C, S, Q, T) are
  flattened into ``CURVE_SEGMENTS`` segments; arcs (A) are refused.
* Anchors JSON: ``{"anchors": [[[xs, ys], [xt, yt]], ...]}``.

Limits (each refused with a :class:`ShapeTooLargeError` naming it): file size
``MAX_FILE_BYTES``, JSON nesting ``MAX_JSON_DEPTH``, points per shape
(``max_points``, default ``DEFAULT_MAX_POINTS``), ``MAX_ANCHORS`` pairs.
"""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.shape_rings import (
    PathError,
    ShapeError,
    TooFewAnchorsError,
    ring_signed_area,
)
from conformorph.pipelines.job_fields import FieldRangeError, check_extent
from conformorph.pipelines.json_depth import json_depth
from conformorph.pipelines.svg_path import (
    CURVE_SEGMENTS,
    ShapeTooLargeError,
    SvgPathError,
    parse_svg_path,
)

__all__ = [
    "CURVE_SEGMENTS",
    "DEFAULT_MAX_POINTS",
    "MAX_ANCHORS",
    "MAX_FILE_BYTES",
    "MAX_JSON_DEPTH",
    "ShapeTooLargeError",
    "SvgPathError",
    "json_depth",
    "parse_anchor_paths",
    "parse_shape",
    "parse_svg_path",
    "read_anchor_paths",
    "read_anchors",
    "read_shape",
]

#: Largest shape or anchors file read, in bytes (the API's upload limit is the same).
MAX_FILE_BYTES = 64 * 1024 * 1024
#: Deepest JSON nesting read (a shape needs 4 levels: object, rings, ring, point).
MAX_JSON_DEPTH = 32
#: Default cap on the points of one shape, all rings together (``--max-points``;
#: the API's ``max_shape_points``). The compatible triangulation's memory grows
#: with the square of the boundary points (measured on a circle against a
#: shifted ellipse: 2000 points 2.5 GB and 170 s, 5000 points over 14 GB).
DEFAULT_MAX_POINTS = 2_000
#: Most anchor pairs read.
MAX_ANCHORS = 1_000
#: Deepest element nesting read in an SVG file.
MAX_XML_DEPTH = 256
#: what :func:`has_nested_entity` looks at: an entity declaration's start, its end, a reference
_ENTITY_TOKENS = re.compile(r"<!ENTITY|[>&]", re.IGNORECASE)


def has_nested_entity(text: str) -> bool:
    """True when an XML entity declaration refers to other entities (``<!ENTITY`` then
    ``&`` before its ``>``: the "billion laughs" file).

    One pass over the text: the pattern ``<!ENTITY[^>]*&`` searched instead restarts
    at every ``<!ENTITY`` of a run that never closes, quadratic in it (issue 30:
    8,000 of them, 72 KB, took 0.5 s; 60,000 would take half a minute).
    """
    inside = False
    for m in _ENTITY_TOKENS.finditer(text):
        token = m.group()
        if token == "&":
            if inside:
                return True
        elif token == ">":
            inside = False
        else:
            inside = True
    return False


def _svg_path_data(text: str) -> list[str]:
    """The ``d`` of every ``<path>`` of an SVG document, read incrementally so that
    nesting deeper than ``MAX_XML_DEPTH`` is refused as soon as it is reached."""
    parser: ET.XMLPullParser = ET.XMLPullParser(events=("start", "end"))
    ds: list[str] = []
    depth = 0
    try:
        for k in range(0, max(len(text), 1), 1 << 16):
            parser.feed(text[k : k + (1 << 16)])
            for item in parser.read_events():
                event, el = item[0], item[-1]
                if not isinstance(el, ET.Element):
                    continue
                if event == "end":
                    depth -= 1
                    el.clear()  # keep memory flat
                    continue
                depth += 1
                if depth > MAX_XML_DEPTH:
                    raise ShapeTooLargeError(
                        f"SVG file nests elements more than {MAX_XML_DEPTH} levels deep"
                    )
                if el.tag.split("}")[-1] == "path":
                    ds.append(el.get("d", ""))
        parser.close()
    except ET.ParseError as exc:
        raise ShapeError(f"SVG file is not valid XML: {exc}") from exc
    return ds


def _svg_rings(text: str, max_points: int) -> list[NDArray[np.float64]]:
    stripped = text.lstrip()
    if stripped.startswith("<"):
        if has_nested_entity(text):
            raise ShapeError(
                "SVG file declares an entity that refers to other entities; such declarations "
                "are not read (remove the <!ENTITY ...> lines)"
            )
        ds = _svg_path_data(text)
        if not ds:
            raise ShapeError("SVG file has no <path> element")
        rings: list[NDArray[np.float64]] = []
        for d in ds:
            left = max_points - sum(r.shape[0] for r in rings)
            rings += parse_svg_path(d, max_points=left)
    else:
        rings = parse_svg_path(text, max_points=max_points)
    if not rings:
        raise ShapeError("SVG path data has no closed ring with 3 or more points")
    rings = [r * [1.0, -1.0] for r in rings]  # y down → y up
    outer = int(np.argmax([abs(ring_signed_area(r)) for r in rings]))
    return [rings[outer], *(r for k, r in enumerate(rings) if k != outer)]


def _read_text(path: Path, max_bytes: int) -> str:
    """The file's text, refused beyond ``max_bytes`` before anything is read."""
    size = path.stat().st_size
    if size > max_bytes:
        raise ShapeTooLargeError(f"{path.name}: {size} bytes; the limit is {max_bytes}")
    return _decode(path.read_bytes(), path.name)


def _decode(data: bytes, name: str) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ShapeError(f"{name}: not UTF-8 text ({exc.reason} at byte {exc.start})") from exc


def _parse_json(text: str, name: str) -> Any:
    """Parse a JSON document, refusing over-deep ones with a :class:`ShapeError`."""
    depth = json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise ShapeTooLargeError(
            f"{name}: JSON nested {depth} levels deep; at most {MAX_JSON_DEPTH} are read"
        )
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ShapeError(f"{name}: not valid JSON ({exc})") from exc
    except ValueError as exc:  # an integer of thousands of digits
        raise ShapeError(f"{name}: not valid JSON (a number has too many digits)") from exc
    except RecursionError as exc:  # pragma: no cover - json_depth refuses these first
        raise ShapeTooLargeError(f"{name}: JSON nested too deeply") from exc


def _load_json(path: Path, max_bytes: int) -> Any:
    """Parse a JSON file, refusing oversized or over-deep ones with a :class:`ShapeError`."""
    return _parse_json(_read_text(path, max_bytes), path.name)


def _json_rings(data: Any, name: str, max_points: int) -> list[NDArray[np.float64]]:
    """The rings of a decoded shape document ``{"rings": [...]}``."""
    if not isinstance(data, dict) or not isinstance(data.get("rings"), list) or not data["rings"]:
        raise ShapeError(f"{name}: expected an object with a non-empty list 'rings'")
    n_points = sum(len(r) if isinstance(r, list) else 0 for r in data["rings"])
    if n_points > max_points:
        raise ShapeTooLargeError(f"{name}: {n_points} points; the limit is {max_points} per shape")
    rings = []
    for k, r in enumerate(data["rings"]):
        try:
            a = np.asarray(r, dtype=np.float64)
        except (TypeError, ValueError, OverflowError) as exc:
            raise ShapeError(f"{name}: ring {k} is not a list of [x, y] numbers") from exc
        if a.ndim != 2 or a.shape[1] != 2:
            raise ShapeError(
                f"{name}: ring {k} must be a list of [x, y] pairs, got shape {a.shape}"
            )
        rings.append(a)
    return rings


def parse_shape(
    text: str, suffix: str, name: str, *, max_points: int = DEFAULT_MAX_POINTS
) -> list[NDArray[np.float64]]:
    """The rings of a 2D shape document given as text.

    Parameters
    ----------
    text : str
        The document: shape JSON, an SVG file, or bare SVG path data.
    suffix : str
        The file's suffix (``".json"``, ``".svg"``, or another: detected by
        content).
    name : str
        What messages call the document (a file name, "the uploaded shape").
    max_points : int, optional
        Most points over all rings.

    Returns
    -------
    list of (k, 2) float64
        Outer ring first, as :func:`read_shape`.

    Raises
    ------
    ShapeTooLargeError, SvgPathError, ShapeError
        As :func:`read_shape`.
    """
    if suffix.lower() == ".svg" or (
        suffix.lower() != ".json" and not text.lstrip().startswith("{")
    ):
        # the outer ring is found by area: out-of-range points overflow it, and are
        # refused just below (check_ring_coordinates), not warned about here
        with np.errstate(over="ignore", invalid="ignore"):
            rings = _svg_rings(text, max_points)
    else:
        rings = _json_rings(_parse_json(text, name), name, max_points)
    check_ring_coordinates(rings, name)
    return rings


class ShapeRangeError(ShapeError):
    """Coordinates outside the range the numerics honour (:mod:`conformorph.pipelines.job_fields`)."""

    code = "out_of_range"


def check_ring_coordinates(rings: list[NDArray[np.float64]], name: str) -> None:
    """Every coordinate finite and within ``COORDINATE_LIMIT``, the extent not lost in them.

    Parameters
    ----------
    rings : list of (k, 2) float64
    name : str
        What messages call the shape.

    Raises
    ------
    ShapeRangeError
        A coordinate that is not finite or beyond ``COORDINATE_LIMIT`` (``1e300``
        overflowed the areas: "ring has zero area"), or a shape whose extent is
        below ``EXTENT_RTOL`` of its coordinates' magnitude.
    """
    pts = np.concatenate([np.asarray(r, dtype=np.float64).reshape(-1, 2) for r in rings])
    if pts.size == 0:
        return
    if not np.all(np.isfinite(pts)):
        raise ShapeRangeError(f"{name}: coordinates must be finite numbers")
    largest = float(np.abs(pts).max())
    # the extent from the halved corners, which cannot overflow for finite inputs
    half = (pts.max(axis=0) / 2.0) - (pts.min(axis=0) / 2.0)
    extent = 2.0 * float(np.hypot(half[0], half[1]))
    try:
        check_extent(largest, extent, name)
    except FieldRangeError as exc:
        raise ShapeRangeError(str(exc)) from exc


def read_shape(
    source: str | Path, *, max_points: int = DEFAULT_MAX_POINTS, max_bytes: int = MAX_FILE_BYTES
) -> list[NDArray[np.float64]]:
    """Read the rings of a 2D shape file.

    Parameters
    ----------
    source : str or Path
        A ``.json`` file ``{"rings": [...]}``, an ``.svg`` file, or a file of
        bare SVG path data (detected by content when the suffix says nothing).
    max_points : int, optional
        Most points over all rings (Bézier curves counted after flattening).
    max_bytes : int, optional
        Largest file read.

    Returns
    -------
    list of (k, 2) float64
        Outer ring first (orientation not yet checked: use
        :func:`conformorph.geometry.shape_rings.validate_rings`).

    Raises
    ------
    ShapeTooLargeError
        A file over ``max_bytes``, JSON nested deeper than ``MAX_JSON_DEPTH``,
        or more than ``max_points`` points.
    SvgPathError
        Malformed SVG path data.
    ShapeError
        Unreadable content, missing ``rings``, malformed rings.
    OSError
        If the file cannot be read.
    """
    path = Path(source)
    return parse_shape(_read_text(path, max_bytes), path.suffix, path.name, max_points=max_points)


def read_anchors(source: str | Path, *, min_pairs: int = 2) -> NDArray[np.float64]:
    """Read an anchors file ``{"anchors": [[[xs, ys], [xt, yt]], ...]}``.

    Parameters
    ----------
    source : str or Path
    min_pairs : int, optional
        Fewest pairs accepted (default 2; 0 reads seeds of the automatic matching).

    Returns
    -------
    anchors : (a, 2, 2) float64
        ``anchors[i, 0]`` in the source shape, ``anchors[i, 1]`` in the target.

    Raises
    ------
    TooFewAnchorsError
        Fewer than two pairs.
    ShapeTooLargeError
        A file over ``MAX_FILE_BYTES``, JSON nested deeper than
        ``MAX_JSON_DEPTH``, or more than ``MAX_ANCHORS`` pairs.
    ShapeError
        Malformed content.
    """
    path = Path(source)
    data: Any = _load_json(path, MAX_FILE_BYTES)
    if not isinstance(data, dict) or "anchors" not in data:
        raise ShapeError(f"{path.name}: expected an object with a list 'anchors'")
    if isinstance(data["anchors"], list) and len(data["anchors"]) > MAX_ANCHORS:
        raise ShapeTooLargeError(
            f"{path.name}: {len(data['anchors'])} anchor pairs; at most {MAX_ANCHORS} are read"
        )
    try:
        a = np.asarray(data["anchors"], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"{path.name}: anchors must be [[[xs, ys], [xt, yt]], ...]") from exc
    if a.size == 0:
        a = a.reshape(0, 2, 2)
    if a.ndim != 3 or a.shape[1:] != (2, 2):
        raise ShapeError(
            f"{path.name}: anchors must be [[[xs, ys], [xt, yt]], ...], got shape {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise ShapeError(f"{path.name}: anchors must be finite numbers")
    if a.shape[0] < min_pairs:
        raise TooFewAnchorsError(
            f"{path.name}: {a.shape[0]} anchor pair(s) given, at least 2 are needed"
        )
    return a


def parse_anchor_paths(value: Any, n_anchors: int, where: str = "paths") -> list[list[int]]:
    """Check the optional ``"paths"`` of an anchors document: lists of anchor indices.

    Parameters
    ----------
    value : Any
        The decoded JSON value (``None`` when absent).
    n_anchors : int
        Number of anchor pairs the indices refer to.
    where : str
        Name used in messages.

    Returns
    -------
    list of list of int
        Empty when ``value`` is ``None``.

    Raises
    ------
    PathError
        Not a list of lists of at least two integers, or an index out of
        range; ``index`` names the offending path. Whether the paths lie in
        the shapes is checked by :func:`conformorph.geometry.patch_dissection.dissect_shapes`.
    ShapeTooLargeError
        More than ``MAX_ANCHORS`` paths.
    """
    if value is None:
        return []
    if not isinstance(value, list):
        raise PathError(f"{where} must be a list of [i, …, j] anchor-index lists", 0)
    if len(value) > MAX_ANCHORS:
        raise ShapeTooLargeError(f"{where}: {len(value)} paths; at most {MAX_ANCHORS} are read")
    out = []
    for k, path in enumerate(value):
        if not (
            isinstance(path, list)
            and 2 <= len(path) <= n_anchors
            and all(isinstance(x, int) and not isinstance(x, bool) for x in path)
        ):
            raise PathError(
                f"{where}[{k}] must be [i, …, j], at least two anchor indices; got {path!r}", k
            )
        for x in path:
            if not 0 <= x < n_anchors:
                raise PathError(f"{where}[{k}] names anchor {x}; there are {n_anchors} anchors", k)
        out.append([int(x) for x in path])
    return out


def read_anchor_paths(source: str | Path) -> list[list[int]]:
    """Read the optional dissection paths of an anchors file: ``{"anchors": …, "paths": [[i, …, j], …]}``.

    A path runs from boundary anchor i through interior anchors to boundary
    anchor j, straight between consecutive ones, in both shapes
    (:func:`conformorph.geometry.patch_dissection.dissect_shapes`).

    Parameters
    ----------
    source : str or Path

    Returns
    -------
    list of list of int
        Empty when the file has no ``"paths"``.

    Raises
    ------
    PathError, ShapeError
        As :func:`parse_anchor_paths` and :func:`read_anchors`.
    """
    path = Path(source)
    data: Any = _load_json(path, MAX_FILE_BYTES)
    n = len(read_anchors(path))
    return parse_anchor_paths(data.get("paths"), n, f"{path.name}: paths")
