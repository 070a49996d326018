"""Reading 2D shapes (JSON rings or SVG path data) and anchor files.

* Shape JSON: ``{"rings": [outer, hole, ...]}``, each ring a list of
  ``[x, y]`` (y up), the first point not repeated (a repeat is dropped later).
* SVG: every ``<path d="...">`` of the file, or a bare path-data string;
  each closed sub-path is a ring, the one enclosing the largest area is the
  outer boundary. SVG's y axis points down, so y is negated. Straight
  commands (M, L, H, V, Z) are exact; Bézier curves (C, S, Q, T) are
  flattened into ``CURVE_SEGMENTS`` segments; arcs (A) are refused.
* Anchors JSON: ``{"anchors": [[[xs, ys], [xt, yt]], ...]}``.
"""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from geometry.shape_rings import ShapeError, TooFewAnchorsError, ring_signed_area

#: Segments per flattened Bézier curve.
CURVE_SEGMENTS = 8

_TOKEN = re.compile(r"[MmLlHhVvZzCcSsQqTtAa]|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def parse_svg_path(d: str) -> list[NDArray[np.float64]]:
    """Rings of an SVG path-data string, in SVG coordinates (y down).

    Parameters
    ----------
    d : str
        Path data, e.g. ``"M0,0 L1,0 L0,1 Z"``.

    Returns
    -------
    list of (k, 2) float64
        One array per sub-path with at least 3 points (closing point dropped).

    Raises
    ------
    ShapeError
        On an unknown command, an arc, or a malformed number sequence.
    """
    tokens = _TOKEN.findall(d)
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
                raise ShapeError(f"SVG path: command {cmd!r} needs {k} numbers")
            out.append(float(tokens[i]))
            i += 1
        return out

    def flush() -> None:
        nonlocal cur
        pts = cur
        if len(pts) > 1 and np.allclose(pts[0], pts[-1]):
            pts = pts[:-1]
        if len(pts) >= 3:
            rings.append(pts)
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
            raise ShapeError("SVG path must start with a command")
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
        else:  # pragma: no cover - the tokenizer only yields known letters
            raise ShapeError(f"unknown SVG command {cmd!r}")
    flush()
    return [np.array(r, dtype=np.float64) for r in rings]


def _svg_rings(text: str) -> list[NDArray[np.float64]]:
    stripped = text.lstrip()
    if stripped.startswith("<"):
        try:
            root = ET.fromstring(text)
        except ET.ParseError as exc:
            raise ShapeError(f"SVG file is not valid XML: {exc}") from exc
        ds = [el.get("d", "") for el in root.iter() if el.tag.split("}")[-1] == "path"]
        if not ds:
            raise ShapeError("SVG file has no <path> element")
        rings = [r for d in ds for r in parse_svg_path(d)]
    else:
        rings = parse_svg_path(text)
    if not rings:
        raise ShapeError("SVG path data has no closed ring with 3 or more points")
    rings = [r * [1.0, -1.0] for r in rings]  # y down → y up
    outer = int(np.argmax([abs(ring_signed_area(r)) for r in rings]))
    return [rings[outer], *(r for k, r in enumerate(rings) if k != outer)]


def read_shape(source: str | Path) -> list[NDArray[np.float64]]:
    """Read the rings of a 2D shape file.

    Parameters
    ----------
    source : str or Path
        A ``.json`` file ``{"rings": [...]}``, an ``.svg`` file, or a file of
        bare SVG path data (detected by content when the suffix says nothing).

    Returns
    -------
    list of (k, 2) float64
        Outer ring first (orientation not yet checked: use
        :func:`geometry.shape_rings.validate_rings`).

    Raises
    ------
    ShapeError
        Unreadable content, missing ``rings``, malformed rings.
    OSError
        If the file cannot be read.
    """
    path = Path(source)
    text = path.read_text(encoding="utf-8")
    if path.suffix.lower() == ".svg" or (
        path.suffix.lower() != ".json" and not text.lstrip().startswith("{")
    ):
        return _svg_rings(text)
    try:
        data: Any = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ShapeError(f"{path.name}: not valid JSON ({exc})") from exc
    if not isinstance(data, dict) or not isinstance(data.get("rings"), list) or not data["rings"]:
        raise ShapeError(f"{path.name}: expected an object with a non-empty list 'rings'")
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
    ShapeError
        Malformed content.
    """
    path = Path(source)
    try:
        data: Any = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ShapeError(f"{path.name}: not valid JSON ({exc})") from exc
    if not isinstance(data, dict) or "anchors" not in data:
        raise ShapeError(f"{path.name}: expected an object with a list 'anchors'")
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
