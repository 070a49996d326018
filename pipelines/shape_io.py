"""Reading 2D shapes (JSON rings or SVG path data) and anchor files.

* Shape JSON: ``{"rings": [outer, hole, ...]}``, each ring a list of
  ``[x, y]`` (y up), the first point not repeated (a repeat is dropped later).
* Shape JSON of several parts: ``{"parts": [{"rings": [...]}, ...]}``.
* SVG: the whole document, read by :mod:`conformorph.pipelines.svg_document`
  (svgelements behind a safe pre-check): every element's fill by its fill
  rule and its stroke's outline, united; each polygon of the union is a part
  (an outer ring and its holes). SVG's y axis points down, so y is negated.
  Bare path data reads as one path with ``fill-rule="evenodd"``.
* Anchors JSON: ``{"anchors": [[[xs, ys], [xt, yt]], ...]}``.

Limits (each refused with a :class:`ShapeTooLargeError` naming it): file size
``MAX_FILE_BYTES``, JSON nesting ``MAX_JSON_DEPTH``, points per shape
(``max_points``, default ``DEFAULT_MAX_POINTS``), ``MAX_ANCHORS`` pairs.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.shape_rings import (
    PathError,
    ShapeError,
    TooFewAnchorsError,
)
from conformorph.pipelines.job_fields import FieldRangeError, check_extent
from conformorph.pipelines.json_depth import json_depth
from conformorph.pipelines.svg_document import MAX_XML_DEPTH, read_svg_shape
from conformorph.pipelines.svg_path import (
    TOKEN_ALLOWANCE,
    TOKENS_PER_POINT,
    ShapeTooLargeError,
    SvgPathError,
    check_path_data,
    parse_svg_path,
)

__all__ = [
    "DEFAULT_MAX_POINTS",
    "MAX_ANCHORS",
    "MAX_FILE_BYTES",
    "MAX_JSON_DEPTH",
    "MAX_XML_DEPTH",
    "ShapeDocument",
    "ShapeTooLargeError",
    "SvgPathError",
    "json_depth",
    "parse_anchor_paths",
    "parse_shape",
    "parse_shape_parts",
    "parse_svg_path",
    "read_anchor_paths",
    "read_anchors",
    "read_shape",
    "read_shape_parts",
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
@dataclass(frozen=True)
class ShapeDocument:
    """A shape file's parts.

    Attributes
    ----------
    parts : list of list of (k, 2) float64
        Per part (largest first), the outer ring then the holes, y up.
    notes : tuple of str
        What reading did beyond parsing (strokes outlined, fill rules,
        simplification; :class:`conformorph.pipelines.svg_document.SvgShape`).
    stroked : int
        Stroked elements outlined (SVG only).
    """

    parts: list[list[NDArray[np.float64]]]
    notes: tuple[str, ...] = ()
    stroked: int = 0


def _svg_document(text: str, max_points: int) -> ShapeDocument:
    """An SVG file, or bare path data (read as one ``<path fill-rule="evenodd">``: each
    inner ring a hole, as this reader always took them)."""
    if not text.lstrip().startswith("<"):
        cap = TOKENS_PER_POINT * max_points + TOKEN_ALLOWANCE
        check_path_data(text, cap)  # positions in the caller's text
        text = (
            '<svg xmlns="http://www.w3.org/2000/svg"><path fill-rule="evenodd" '
            f"d={quoteattr(text)}/></svg>"
        )
    shape = read_svg_shape(text, max_points=max_points)
    return ShapeDocument(shape.parts, shape.notes, shape.stroked)


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


def _json_parts(data: Any, name: str, max_points: int) -> ShapeDocument:
    """The parts of a decoded shape document: ``{"rings": [...]}`` (one part) or
    ``{"parts": [{"rings": [...]}, ...]}``."""
    if isinstance(data, dict) and "parts" in data and "rings" not in data:
        if not isinstance(data["parts"], list) or not data["parts"]:
            raise ShapeError(f"{name}: 'parts' must be a non-empty list of {{'rings': [...]}}")
        parts, left = [], max_points
        for k, part in enumerate(data["parts"]):
            rings = _json_rings(part, f"{name}: parts[{k}]", left)
            left -= sum(r.shape[0] for r in rings)
            parts.append(rings)
        return ShapeDocument(parts)
    return ShapeDocument([_json_rings(data, name, max_points)])


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


def parse_shape_parts(
    text: str, suffix: str, name: str, *, max_points: int = DEFAULT_MAX_POINTS
) -> ShapeDocument:
    """The parts of a 2D shape document given as text.

    Parameters
    ----------
    text : str
        The document: shape JSON (``{"rings": …}`` or ``{"parts": [{"rings":
        …}, …]}``), an SVG file (:mod:`conformorph.pipelines.svg_document`),
        or bare SVG path data.
    suffix : str
        The file's suffix (``".json"``, ``".svg"``, or another: detected by
        content).
    name : str
        What messages call the document (a file name, "the uploaded shape").
    max_points : int, optional
        Most points over all rings of all parts.

    Returns
    -------
    ShapeDocument
        Parts largest first, each outer ring first (orientation not yet
        checked: :func:`conformorph.geometry.shape_rings.validate_rings`).

    Raises
    ------
    ShapeTooLargeError, SvgPathError, ShapeError
        As :func:`read_shape`.
    """
    if suffix.lower() == ".svg" or (
        suffix.lower() != ".json" and not text.lstrip().startswith("{")
    ):
        # out-of-range points overflow the areas that order the rings; they are refused
        # just below (check_ring_coordinates), not warned about here
        with np.errstate(over="ignore", invalid="ignore"):
            doc = _svg_document(text, max_points)
    else:
        doc = _json_parts(_parse_json(text, name), name, max_points)
    check_ring_coordinates([r for part in doc.parts for r in part], name)
    return doc


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


def parse_shape(
    text: str, suffix: str, name: str, *, max_points: int = DEFAULT_MAX_POINTS
) -> list[NDArray[np.float64]]:
    """The rings of a one-part 2D shape document given as text.

    Parameters
    ----------
    text, suffix, name, max_points
        As :func:`parse_shape_parts`.

    Returns
    -------
    list of (k, 2) float64
        Outer ring first, as :func:`read_shape`.

    Raises
    ------
    ShapeTooLargeError, SvgPathError, ShapeError
        As :func:`read_shape`; a shape of several parts (read it with
        :func:`parse_shape_parts`).
    """
    doc = parse_shape_parts(text, suffix, name, max_points=max_points)
    if len(doc.parts) != 1:
        raise ShapeError(
            f"{name}: {len(doc.parts)} separate parts; this reader takes one (parse_shape_parts "
            "reads several)"
        )
    return doc.parts[0]


def read_shape_parts(
    source: str | Path, *, max_points: int = DEFAULT_MAX_POINTS, max_bytes: int = MAX_FILE_BYTES
) -> ShapeDocument:
    """Read the parts of a 2D shape file (as :func:`parse_shape_parts`).

    Parameters
    ----------
    source : str or Path
    max_points : int, optional
    max_bytes : int, optional

    Returns
    -------
    ShapeDocument

    Raises
    ------
    ShapeTooLargeError, SvgPathError, ShapeError, OSError
        As :func:`read_shape`.
    """
    path = Path(source)
    return parse_shape_parts(
        _read_text(path, max_bytes), path.suffix, path.name, max_points=max_points
    )


def read_shape(
    source: str | Path, *, max_points: int = DEFAULT_MAX_POINTS, max_bytes: int = MAX_FILE_BYTES
) -> list[NDArray[np.float64]]:
    """Read the rings of a one-part 2D shape file.

    Parameters
    ----------
    source : str or Path
        A ``.json`` file ``{"rings": [...]}``, an ``.svg`` file, or a file of
        bare SVG path data (detected by content when the suffix says nothing).
    max_points : int, optional
        Most points over all rings (as written: a curve counts one).
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
        Unreadable content, missing ``rings``, malformed rings, several parts
        (:func:`read_shape_parts` reads those).
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
