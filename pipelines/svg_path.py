"""SVG path data read as polylines: a strict check of the text, then svgelements.

The geometry comes from ``svgelements`` (MIT; every command of SVG 1.1 and 2,
arcs included, with its implicit-command and compact-flag rules). In front of
it, :func:`check_path_data` reads the text once more with a small tokenizer, to
give a malformed file a message with a character position (svgelements, like a
browser, raises a bare ``ValueError`` or draws up to the error) and to bound the
work before parsing: the tokens read stop at ``TOKENS_PER_POINT`` per allowed
point.

Curves (quadratic and cubic Béziers, elliptical arcs) are flattened
adaptively: each into the fewest equal parameter steps that keep it within a
distance ``tol`` of its chords; the caller chooses ``tol`` relative to the
drawing's size. A polynomial curve of degree d with control points P_0 … P_d,
cut into n equal parameter steps, stays within

    d (d - 1) / 8 · max_i |P_i - 2 P_{i+1} + P_{i+2}| / n²

of its chord polygon (Wang 1984; e.g. Sederberg, *Computer Aided Geometric
Design*, §10.6): :func:`bezier_segment_count` takes the least n that keeps this
bound under ``tol``. An arc of radius r gets steps of 2 acos(1 - tol / r), the
angle of a chord whose sagitta is ``tol``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import svgelements as se
from numpy.typing import ArrayLike, NDArray

from conformorph.geometry.shape_rings import ShapeError
from conformorph.geometry.tolerances import SVG_FLATTEN_RTOL

#: Most segments one curve is cut into, however tight the tolerance (a bound on
#: the work a hostile control polygon can ask for).
MAX_CURVE_SEGMENTS = 256


def bezier_segment_count(ctrl: ArrayLike, tol: float) -> int:
    """The fewest equal parameter steps that keep a Bézier curve within ``tol`` of its chords.

    Parameters
    ----------
    ctrl : (d + 1, 2) array_like
        Control points, degree d ≥ 1 (a line needs one segment).
    tol : float
        Largest distance between the curve and its polygon (> 0).

    Returns
    -------
    int
        n in [1, ``MAX_CURVE_SEGMENTS``] with d (d - 1) / 8 · M / n² ≤ tol, M the
        largest second difference of the control points (Wang's bound).

    Raises
    ------
    ValueError
        ``ctrl`` not (k, 2) with k ≥ 2, not finite, or ``tol`` not positive.

    Examples
    --------
    >>> bezier_segment_count([[0, 0], [1, 2], [2, 0]], 0.01)
    10
    """
    P = np.asarray(ctrl, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 2:
        raise ValueError(f"ctrl must have shape (k, 2) with k >= 2, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError("ctrl must be finite")
    if not tol > 0:
        raise ValueError(f"tol must be positive, got {tol}")
    d = P.shape[0] - 1
    if d < 2:
        return 1
    M = float(np.max(np.linalg.norm(P[:-2] - 2 * P[1:-1] + P[2:], axis=1)))
    n = math.ceil(math.sqrt(d * (d - 1) / 8.0 * M / tol)) if M > 0 else 1
    return int(min(max(n, 1), MAX_CURVE_SEGMENTS))


def bezier_points(ctrl: ArrayLike, n: int) -> NDArray[np.float64]:
    """The n points after the start of a Bézier curve, at parameters k / n, k = 1 … n.

    Parameters
    ----------
    ctrl : (d + 1, 2) array_like
        Control points (any degree d ≥ 1), evaluated in Bernstein form.
    n : int
        Number of steps (≥ 1).

    Returns
    -------
    (n, 2) float64
        The last row is the end point ``ctrl[-1]`` exactly.

    Examples
    --------
    >>> bezier_points([[0, 0], [1, 2], [2, 0]], 2).tolist()
    [[1.0, 1.0], [2.0, 0.0]]
    """
    P = np.asarray(ctrl, dtype=np.float64)
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    d = P.shape[0] - 1
    t = (np.arange(1, n + 1) / n)[:, None]
    out = np.zeros((n, 2))
    for i in range(d + 1):
        out += math.comb(d, i) * (1 - t) ** (d - i) * t**i * P[i]
    out[-1] = P[-1]
    return out


#: Most tokens read per allowed point (a cubic Bézier, the wordiest command,
#: takes 7 tokens for at least one point), plus a fixed allowance.
TOKENS_PER_POINT, TOKEN_ALLOWANCE = 8, 1_000

#: One token of SVG path data: a command letter, a number, a separator, or anything else.
_TOKEN = re.compile(
    r"(?P<cmd>[A-Za-z])|(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)|(?P<sep>[\s,]+)|(?P<bad>.)",
    re.DOTALL,
)
#: Numbers each command takes (arcs: at least five, since their two flags may be
#: written without separators, "a1 1 0 012 2", which this tokenizer reads as one number).
_ARITY = {"M": 2, "L": 2, "T": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4, "A": 5, "Z": 0}


class ShapeTooLargeError(ShapeError):
    """A shape or anchors document over the size limits (bytes, nesting depth, points, anchors)."""

    code = "shape_too_large"


class SvgPathError(ShapeError):
    """SVG path data that cannot be read: an unknown command, a stray character, misplaced numbers."""

    code = "bad_svg_path"


def svg_tokens(d: str, max_tokens: int | None = None) -> list[tuple[str, int]]:
    """Commands and numbers of path data with their character positions (separators dropped).

    Raises
    ------
    SvgPathError
        An unknown command letter or a stray character (with its position).
    ShapeTooLargeError
        More than ``max_tokens`` tokens (reading stops there).
    """
    out: list[tuple[str, int]] = []
    for m in _TOKEN.finditer(d):
        kind, text, at = m.lastgroup, m.group(), m.start()
        if kind == "sep":
            continue
        if kind == "bad":
            raise SvgPathError(f"SVG path: unexpected character {text!r} at position {at}")
        if kind == "cmd" and text.upper() not in _ARITY:
            raise SvgPathError(f"SVG path: unknown command {text!r} at position {at}")
        out.append((text, at))
        if max_tokens is not None and len(out) > max_tokens:
            raise ShapeTooLargeError(
                f"SVG path data has more than {max_tokens} commands and numbers by position "
                f"{at}; the limit per shape allows no more"
            )
    return out


def check_path_data(d: str, max_tokens: int | None = None) -> tuple[int, int]:
    """Check path data's grammar, naming the first fault by its character position.

    Parameters
    ----------
    d : str
        Path data.
    max_tokens : int, optional
        Refuse more commands and numbers than this.

    Returns
    -------
    tokens : int
        The number of tokens (commands and numbers).
    vertices : int
        The vertices written (one per command repetition; an arc's count is
        rounded down, since its flags may be written without separators): at
        most :func:`written_points`, known before any geometry is built.

    Raises
    ------
    SvgPathError
        An unknown command or character, numbers before the first command or
        after ``Z`` (which takes none), or a command short of numbers.
    ShapeTooLargeError
        More than ``max_tokens`` tokens.
    """
    toks = svg_tokens(d, max_tokens)
    cmd, count, cmd_at = "", 0, 0
    vertices = 0

    def finish() -> None:
        nonlocal vertices
        k = _ARITY[cmd.upper()] if cmd else 0
        if k:
            vertices += max(1, count // 7) if cmd.upper() == "A" else count // k
        if cmd and k and (count < k or (cmd.upper() != "A" and count % k)):
            raise SvgPathError(
                f"SVG path: command {cmd!r} needs {k} numbers (position {cmd_at})"
                if count < k
                else f"SVG path: command {cmd!r} at position {cmd_at} takes numbers in "
                f"groups of {k}, got {count}"
            )

    for text, at in toks:
        if text.isalpha():
            finish()
            cmd, count, cmd_at = text, 0, at
            continue
        if cmd == "":
            raise SvgPathError(f"SVG path must start with a command, got {text!r} at position {at}")
        if cmd in "Zz":
            raise SvgPathError(
                f"SVG path: number {text!r} at position {at} follows {cmd!r}, "
                "which takes none (start a new sub-path with M)"
            )
        count += 1
    if cmd and _ARITY[cmd.upper()] and count < _ARITY[cmd.upper()]:
        raise SvgPathError(
            f"SVG path: command {cmd!r} needs {_ARITY[cmd.upper()]} numbers (position {len(d)})"
        )
    finish()
    return len(toks), vertices


@dataclass(frozen=True)
class Polyline:
    """One flattened sub-path.

    Attributes
    ----------
    points : (k, 2) float64
        Its vertices in drawing order (SVG coordinates, y down), the closing
        point not repeated.
    closed : bool
        Ended by ``Z`` (a stroke then joins its ends; a fill closes every
        sub-path either way).
    """

    points: NDArray[np.float64]
    closed: bool


def _arc_steps(seg: Any, tol: float) -> int:
    r = max(abs(float(seg.rx)), abs(float(seg.ry)), 1e-300)
    half = math.acos(max(-1.0, 1.0 - tol / r))  # half the angle of a chord with sagitta tol
    n = math.ceil(abs(float(seg.sweep)) / (2 * half)) if half > 0 else 1
    return int(min(max(n, 1), MAX_CURVE_SEGMENTS))


def _segment_points(seg: Any, tol: float) -> NDArray[np.float64]:
    """The points after a segment's start: its end for a line, the flattened curve otherwise."""
    if isinstance(seg, se.CubicBezier | se.QuadraticBezier):
        ctrl = np.array(
            [[p.x, p.y] for p in (seg.start, *getattr(seg, "controls", ()), seg.end)]
            if hasattr(seg, "controls")
            else [[p.x, p.y] for p in _bezier_controls(seg)]
        )
        if not np.all(np.isfinite(ctrl)):
            raise SvgPathError("SVG path has a coordinate that is not a finite number")
        return bezier_points(ctrl, bezier_segment_count(ctrl, tol))
    if isinstance(seg, se.Arc):
        n = _arc_steps(seg, tol)
        pts = np.asarray(seg.npoint(np.arange(1, n + 1) / n), dtype=np.float64).reshape(-1, 2)
        pts[-1] = [seg.end.x, seg.end.y]
        return pts
    return np.array([[seg.end.x, seg.end.y]], dtype=np.float64)


def _bezier_controls(seg: Any) -> list[Any]:
    if isinstance(seg, se.CubicBezier):
        return [seg.start, seg.control1, seg.control2, seg.end]
    return [seg.start, seg.control, seg.end]


def path_polylines(path: Any, tol: float) -> list[Polyline]:
    """The sub-paths of an svgelements ``Path`` (already transformed), flattened.

    Parameters
    ----------
    path : svgelements.Path
    tol : float
        Largest distance of a flattened curve from the curve (> 0).

    Returns
    -------
    list of Polyline
        Every sub-path with at least 2 distinct points.

    Raises
    ------
    SvgPathError
        A coordinate that is not finite.
    """
    out: list[Polyline] = []
    cur: list[NDArray[np.float64]] = []
    closed = False

    def flush() -> None:
        if cur:
            pts = np.vstack(cur)
            keep = np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]
            pts = pts[keep]
            if pts.shape[0] > 1 and np.array_equal(pts[0], pts[-1]):
                pts = pts[:-1]
            if not np.all(np.isfinite(pts)):
                raise SvgPathError("SVG path has a coordinate that is not a finite number")
            if pts.shape[0] >= 2:
                out.append(Polyline(pts, closed))

    for seg in path:
        if isinstance(seg, se.Move):
            flush()
            cur, closed = [np.array([[seg.end.x, seg.end.y]], dtype=np.float64)], False
        elif isinstance(seg, se.Close):
            closed = True
            flush()
            cur, closed = [], False
        else:
            if not cur and seg.start is not None:
                cur = [np.array([[seg.start.x, seg.start.y]], dtype=np.float64)]
            cur.append(_segment_points(seg, tol))
    flush()
    return out


def parse_svg_path(
    d: str, *, max_points: int | None = None, tol: float | None = None
) -> list[NDArray[np.float64]]:
    """Rings of an SVG path-data string, in SVG coordinates (y down).

    Parameters
    ----------
    d : str
        Path data, e.g. ``"M0,0 L1,0 L0,1 Z"`` (arcs included).
    max_points : int, optional
        Refuse path data with more vertices than this as written (each
        segment's end, a curve counting one: adaptive flattening adds points
        the author did not write, and the working resolution removes them
        again), and stop reading after ``TOKENS_PER_POINT`` tokens
        per point (plus ``TOKEN_ALLOWANCE``); no limit when None.
    tol : float, optional
        Flattening tolerance; default ``SVG_FLATTEN_RTOL`` times the diagonal
        of the path's bounding box.

    Returns
    -------
    list of (k, 2) float64
        One array per sub-path with at least 3 points (closing point dropped):
        the ring a fill paints, open sub-paths closed as SVG fills them.

    Raises
    ------
    SvgPathError
        As :func:`check_path_data`, or a coordinate that is not finite.
    ShapeTooLargeError
        More than ``max_points`` vertices as written.
    """
    cap = None if max_points is None else TOKENS_PER_POINT * max_points + TOKEN_ALLOWANCE
    check_path_data(d, cap)
    try:
        path = se.Path(d)
    except (ValueError, IndexError) as exc:
        raise SvgPathError(f"SVG path data cannot be read ({type(exc).__name__})") from exc
    n = written_points(path)
    if max_points is not None and n > max_points:
        raise ShapeTooLargeError(
            f"SVG path has {n} points as written, more than {max_points} (the limit per shape)"
        )
    if tol is None:
        tol = SVG_FLATTEN_RTOL * path_size(path)
    return [p.points for p in path_polylines(path, tol) if p.points.shape[0] >= 3]


def written_points(path: Any) -> int:
    """The vertices of a path as written: one per segment end (a curve counts one), closes excluded."""
    return sum(1 for seg in path if not isinstance(seg, se.Close))


def path_size(path: Any) -> float:
    """The diagonal of a path's bounding box (1.0 when it has none or it is not finite)."""
    box = path.bbox()
    if box is None:
        return 1.0
    size = math.hypot(box[2] - box[0], box[3] - box[1])
    return size if math.isfinite(size) and size > 0 else 1.0
