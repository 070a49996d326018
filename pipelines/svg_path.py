"""SVG path data read as rings: tokens, then one command at a time.

Straight commands (M, L, H, V, Z) are exact; Bézier curves (C, S, Q, T) are
flattened into ``CURVE_SEGMENTS`` segments; arcs (A) are refused. Work is
bounded by ``max_points``: the tokens read stop at a multiple of it.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.shape_rings import ShapeError

#: Segments per flattened Bézier curve.
CURVE_SEGMENTS = 8
#: Most tokens read per allowed point (a cubic Bézier, the wordiest command,
#: takes 7 tokens for ``CURVE_SEGMENTS`` points), plus a fixed allowance.
TOKENS_PER_POINT, TOKEN_ALLOWANCE = 8, 1_000

#: One token of SVG path data: a command letter, a number, a separator, or anything else.
_TOKEN = re.compile(
    r"(?P<cmd>[A-Za-z])|(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)|(?P<sep>[\s,]+)|(?P<bad>.)",
    re.DOTALL,
)
_COMMANDS = frozenset("MmLlHhVvZzCcSsQqTtAa")
_CURVE_NUMBERS = {"C": 6, "S": 4, "Q": 4, "T": 2}


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
        if kind == "cmd" and text not in _COMMANDS:
            raise SvgPathError(f"SVG path: unknown command {text!r} at position {at}")
        out.append((text, at))
        if max_tokens is not None and len(out) > max_tokens:
            raise ShapeTooLargeError(
                f"SVG path data has more than {max_tokens} commands and numbers by position "
                f"{at}; the limit per shape allows no more"
            )
    return out


def bezier_points(ctrl: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """The ``CURVE_SEGMENTS`` points after the start of a quadratic (3 control points) or
    cubic (4) Bézier curve, at equal parameter steps.

    Returns
    -------
    (CURVE_SEGMENTS, 2) float64
    """
    t = np.linspace(0, 1, CURVE_SEGMENTS + 1)[1:, None]
    if len(ctrl) == 3:
        return (1 - t) ** 2 * ctrl[0] + 2 * (1 - t) * t * ctrl[1] + t**2 * ctrl[2]
    return (
        (1 - t) ** 3 * ctrl[0]
        + 3 * (1 - t) ** 2 * t * ctrl[1]
        + 3 * (1 - t) * t**2 * ctrl[2]
        + t**3 * ctrl[3]
    )


class _PathReader:
    """The state of reading one path: pen position, sub-path start, rings so far."""

    def __init__(self, d: str, toks: list[tuple[str, int]], max_points: int | None) -> None:
        self.d, self.toks, self.max_points = d, toks, max_points
        self.i = 0
        self.cmd = ""
        self.rings: list[list[tuple[float, float]]] = []
        self.cur: list[tuple[float, float]] = []
        self.n_closed = 0  # points in finished rings
        self.pos = np.zeros(2)
        self.start = np.zeros(2)
        self.last_ctrl: NDArray[np.float64] | None = None
        self.straight: dict[str, Callable[[bool, NDArray[np.float64]], None]] = {
            "M": self.move,
            "L": lambda _r, b: self.line_to(b + self.numbers(2)),
            "H": self.horizontal,
            "V": self.vertical,
            "Z": self.close,
        }

    def numbers(self, k: int) -> list[float]:
        """The next ``k`` numbers of the current command."""
        out = []
        for _ in range(k):
            if self.i >= len(self.toks) or self.toks[self.i][0].isalpha():
                at = self.toks[self.i][1] if self.i < len(self.toks) else len(self.d)
                raise SvgPathError(
                    f"SVG path: command {self.cmd!r} needs {k} numbers (position {at})"
                )
            out.append(float(self.toks[self.i][0]))
            self.i += 1
        return out

    def flush(self) -> None:
        """End the current sub-path: kept as a ring when it has 3 or more points."""
        pts = self.cur
        if len(pts) > 1 and np.allclose(pts[0], pts[-1]):
            pts = pts[:-1]
        if len(pts) >= 3:
            self.rings.append(pts)
            self.n_closed += len(pts)
        self.cur = []

    def over_limit(self) -> bool:
        return self.max_points is not None and self.n_closed + len(self.cur) > self.max_points

    def line_to(self, p: NDArray[np.float64]) -> None:
        self.pos = p
        self.cur.append((float(p[0]), float(p[1])))
        self.last_ctrl = None

    def move(self, rel: bool, base: NDArray[np.float64]) -> None:
        self.flush()
        self.line_to(base + self.numbers(2))
        self.start = self.pos.copy()
        self.cmd = "l" if rel else "L"  # further pairs are line-tos

    def horizontal(self, rel: bool, _base: NDArray[np.float64]) -> None:
        (x,) = self.numbers(1)
        self.line_to(np.array([self.pos[0] + x if rel else x, self.pos[1]]))

    def vertical(self, rel: bool, _base: NDArray[np.float64]) -> None:
        (y,) = self.numbers(1)
        self.line_to(np.array([self.pos[0], self.pos[1] + y if rel else y]))

    def close(self, _rel: bool, _base: NDArray[np.float64]) -> None:
        self.flush()
        self.pos = self.start.copy()
        self.last_ctrl = None

    def curve(self, c: str, base: NDArray[np.float64]) -> None:
        k = _CURVE_NUMBERS[c]
        v = self.numbers(k)
        pts = [base + v[j : j + 2] for j in range(0, k, 2)]
        if c in "ST":
            refl = 2 * self.pos - self.last_ctrl if self.last_ctrl is not None else self.pos.copy()
            pts = [refl, *pts]
        ctrl = [self.pos.copy(), *pts]
        self.cur.extend((float(x), float(y)) for x, y in bezier_points(ctrl))
        self.last_ctrl = ctrl[-2]
        self.pos = ctrl[-1]

    def next_command(self) -> None:
        """Take a command letter, or check that numbers may repeat the current one."""
        text, at = self.toks[self.i]
        if text.isalpha():
            self.cmd = text
            self.i += 1
        elif self.cmd == "":
            raise SvgPathError(f"SVG path must start with a command, got {text!r} at position {at}")
        elif self.cmd in "Zz":
            # Z takes no numbers: without this check the loop would not advance.
            raise SvgPathError(
                f"SVG path: number {text!r} at position {at} follows {self.cmd!r}, "
                "which takes none (start a new sub-path with M)"
            )

    def step(self) -> None:
        """Read one command (or one repetition of it) and draw it."""
        self.next_command()
        if self.over_limit():
            raise ShapeTooLargeError(
                f"SVG path has more than {self.max_points} points (the limit per shape)"
            )
        rel, c = self.cmd.islower(), self.cmd.upper()
        base = self.pos if rel else np.zeros(2)
        if c in self.straight:
            self.straight[c](rel, base)
        elif c in _CURVE_NUMBERS:
            self.curve(c, base)
        else:  # "A"; svg_tokens only yields known letters
            raise ShapeError("SVG arcs (A) are not supported: convert them to curves or lines")


def parse_svg_path(d: str, *, max_points: int | None = None) -> list[NDArray[np.float64]]:
    """Rings of an SVG path-data string, in SVG coordinates (y down).

    Parameters
    ----------
    d : str
        Path data, e.g. ``"M0,0 L1,0 L0,1 Z"``.
    max_points : int, optional
        Refuse path data with more points than this (Bézier points counted
        after flattening), and stop reading after ``TOKENS_PER_POINT`` tokens
        per point (plus ``TOKEN_ALLOWANCE``); no limit when None.

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
    cap = None if max_points is None else TOKENS_PER_POINT * max_points + TOKEN_ALLOWANCE
    reader = _PathReader(d, svg_tokens(d, cap), max_points)
    while reader.i < len(reader.toks):
        reader.step()
    reader.flush()
    if reader.over_limit():
        raise ShapeTooLargeError(
            f"SVG path has more than {max_points} points (the limit per shape)"
        )
    return [np.array(r, dtype=np.float64) for r in reader.rings]
