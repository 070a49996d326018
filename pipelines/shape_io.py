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

from geometry.shape_rings import PathError, ShapeError, TooFewAnchorsError, ring_signed_area
from pipelines.json_depth import json_depth

#: Segments per flattened Bézier curve.
CURVE_SEGMENTS = 8
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

#: One token of SVG path data: a command letter, a number, a separator, or anything else.
_TOKEN = re.compile(
    r"(?P<cmd>[A-Za-z])|(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)|(?P<sep>[\s,]+)|(?P<bad>.)",
    re.DOTALL,
)
_COMMANDS = frozenset("MmLlHhVvZzCcSsQqTtAa")


class ShapeTooLargeError(ShapeError):
    """A shape or anchors document over the size limits (bytes, nesting depth, points, anchors)."""

    code = "shape_too_large"


class SvgPathError(ShapeError):
    """SVG path data that cannot be read: an unknown command, a stray character, misplaced numbers."""

    code = "bad_svg_path"


def _svg_tokens(d: str) -> list[tuple[str, int]]:
    """Commands and numbers of path data with their character positions (separators dropped)."""
    out: list[tuple[str, int]] = []
    for m in _TOKEN.finditer(d):
        kind, text, at = m.lastgroup, m.group(), m.start()
        if kind == "sep":
            continue
        if kind == "bad":
            raise SvgPathError(f"SVG path: unexpected character {text!r} at position {at}")
        if kind == "cmd" and text not in _COMMANDS:
            raise SvgPathError(f"SVG path: unknown command {text!r} at position {at}")
        out.append((text, at))
    return out


def parse_svg_path(d: str, *, max_points: int | None = None) -> list[NDArray[np.float64]]:
    """Rings of an SVG path-data string, in SVG coordinates (y down).

    Parameters
    ----------
    d : str
        Path data, e.g. ``"M0,0 L1,0 L0,1 Z"``.
    max_points : int, optional
        Refuse path data with more points than this (Bézier points counted
        after flattening); no limit when None.

    Returns
    -------
    list of (k, 2) float64
        One array per sub-path with at least 3 points (closing point dropped).

    Raises
    ------
    SvgPathError
        On an unknown command letter or character, numbers where no command
        takes them (after ``Z``, or before the first command), or a command
        short of numbers; each message gives the character position.
    ShapeError
        On an arc (``A``), or when the rings would exceed ``max_points``.
    """
    toks = _svg_tokens(d)
    tokens = [t for t, _ in toks]
    rings: list[list[tuple[float, float]]] = []
    cur: list[tuple[float, float]] = []
    pos = np.zeros(2)
    start = np.zeros(2)
    last_ctrl: NDArray[np.float64] | None = None
    cmd = ""
    i = 0

    def nums(k: int) -> list[float]:
        nonlocal i
        out = []
        for _ in range(k):
            if i >= len(tokens) or tokens[i].isalpha():
                at = toks[i][1] if i < len(tokens) else len(d)
                raise SvgPathError(f"SVG path: command {cmd!r} needs {k} numbers (position {at})")
            out.append(float(tokens[i]))
            i += 1
        return out

    n_closed = 0  # points in finished rings

    def flush() -> None:
        nonlocal cur, n_closed
        pts = cur
        if len(pts) > 1 and np.allclose(pts[0], pts[-1]):
            pts = pts[:-1]
        if len(pts) >= 3:
            rings.append(pts)
            n_closed += len(pts)
        cur = []

    def bezier(ctrl: list[NDArray[np.float64]]) -> None:
        t = np.linspace(0, 1, CURVE_SEGMENTS + 1)[1:, None]
        if len(ctrl) == 3:
            p = (1 - t) ** 2 * ctrl[0] + 2 * (1 - t) * t * ctrl[1] + t**2 * ctrl[2]
        else:
            p = (
                (1 - t) ** 3 * ctrl[0]
                + 3 * (1 - t) ** 2 * t * ctrl[1]
                + 3 * (1 - t) * t**2 * ctrl[2]
                + t**3 * ctrl[3]
            )
        cur.extend((float(x), float(y)) for x, y in p)

    while i < len(tokens):
        if tokens[i].isalpha():
            cmd = tokens[i]
            i += 1
        elif cmd == "":
            raise SvgPathError(
                f"SVG path must start with a command, got {tokens[i]!r} at position {toks[i][1]}"
            )
        elif cmd in "Zz":
            # Z takes no numbers: without this check the loop would not advance.
            raise SvgPathError(
                f"SVG path: number {tokens[i]!r} at position {toks[i][1]} follows {cmd!r}, "
                "which takes none (start a new sub-path with M)"
            )
        if max_points is not None and n_closed + len(cur) > max_points:
            raise ShapeTooLargeError(
                f"SVG path has more than {max_points} points (the limit per shape)"
            )
        rel = cmd.islower()
        c = cmd.upper()
        base = pos if rel else np.zeros(2)
        if c == "M":
            flush()
            pos = base + nums(2)
            start = pos.copy()
            cur.append((float(pos[0]), float(pos[1])))
            cmd = "l" if rel else "L"  # further pairs are line-tos
            last_ctrl = None
        elif c == "L":
            pos = base + nums(2)
            cur.append((float(pos[0]), float(pos[1])))
            last_ctrl = None
        elif c == "H":
            (x,) = nums(1)
            pos = np.array([pos[0] + x if rel else x, pos[1]])
            cur.append((float(pos[0]), float(pos[1])))
            last_ctrl = None
        elif c == "V":
            (y,) = nums(1)
            pos = np.array([pos[0], pos[1] + y if rel else y])
            cur.append((float(pos[0]), float(pos[1])))
            last_ctrl = None
        elif c == "Z":
            flush()
            pos = start.copy()
            last_ctrl = None
        elif c in "CSQT":
            k = {"C": 6, "S": 4, "Q": 4, "T": 2}[c]
            v = nums(k)
            pts = [base + v[j : j + 2] for j in range(0, k, 2)]
            if c in "ST":
                refl = 2 * pos - last_ctrl if last_ctrl is not None else pos.copy()
                pts = [refl, *pts]
            ctrl = [pos.copy(), *pts]
            bezier(ctrl)
            last_ctrl = ctrl[-2]
            pos = ctrl[-1]
        elif c == "A":
            raise ShapeError("SVG arcs (A) are not supported: convert them to curves or lines")
        else:  # pragma: no cover - _svg_tokens only yields known letters
            raise SvgPathError(f"unknown SVG command {cmd!r}")
    flush()
    if max_points is not None and n_closed > max_points:
        raise ShapeTooLargeError(
            f"SVG path has more than {max_points} points (the limit per shape)"
        )
    return [np.array(r, dtype=np.float64) for r in rings]


def _svg_rings(text: str, max_points: int) -> list[NDArray[np.float64]]:
    stripped = text.lstrip()
    if stripped.startswith("<"):
        try:
            root = ET.fromstring(text)
        except ET.ParseError as exc:
            raise ShapeError(f"SVG file is not valid XML: {exc}") from exc
        ds = [el.get("d", "") for el in root.iter() if el.tag.split("}")[-1] == "path"]
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
    try:
        return path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ShapeError(f"{path.name}: not UTF-8 text ({exc.reason} at byte {exc.start})") from exc


def _load_json(path: Path, max_bytes: int) -> Any:
    """Parse a JSON document, refusing oversized or over-deep ones with a :class:`ShapeError`."""
    text = _read_text(path, max_bytes)
    depth = json_depth(text)
    if depth > MAX_JSON_DEPTH:
        raise ShapeTooLargeError(
            f"{path.name}: JSON nested {depth} levels deep; at most {MAX_JSON_DEPTH} are read"
        )
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ShapeError(f"{path.name}: not valid JSON ({exc})") from exc
    except RecursionError as exc:  # pragma: no cover - json_depth refuses these first
        raise ShapeTooLargeError(f"{path.name}: JSON nested too deeply") from exc


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
        :func:`geometry.shape_rings.validate_rings`).

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
    if path.suffix.lower() == ".svg":
        return _svg_rings(_read_text(path, max_bytes), max_points)
    text = _read_text(path, max_bytes)
    if path.suffix.lower() != ".json" and not text.lstrip().startswith("{"):
        return _svg_rings(text, max_points)
    data: Any = _load_json(path, max_bytes)
    if not isinstance(data, dict) or not isinstance(data.get("rings"), list) or not data["rings"]:
        raise ShapeError(f"{path.name}: expected an object with a non-empty list 'rings'")
    n_points = sum(len(r) if isinstance(r, list) else 0 for r in data["rings"])
    if n_points > max_points:
        raise ShapeTooLargeError(
            f"{path.name}: {n_points} points; the limit is {max_points} per shape"
        )
    rings = []
    for k, r in enumerate(data["rings"]):
        try:
            a = np.asarray(r, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ShapeError(f"{path.name}: ring {k} is not a list of [x, y] numbers") from exc
        if a.ndim != 2 or a.shape[1] != 2:
            raise ShapeError(
                f"{path.name}: ring {k} must be a list of [x, y] pairs, got shape {a.shape}"
            )
        rings.append(a)
    return rings


def read_anchors(source: str | Path) -> NDArray[np.float64]:
    """Read an anchors file ``{"anchors": [[[xs, ys], [xt, yt]], ...]}``.

    Parameters
    ----------
    source : str or Path

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
    if a.shape[0] < 2:
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
        the shapes is checked by :func:`geometry.patch_dissection.dissect_shapes`.
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
    (:func:`geometry.patch_dissection.dissect_shapes`).

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
