"""Web outputs of a 2D morph: ``animation.svg`` (SMIL, no script) and ``frames.json``.

``animation.svg`` plays the morph in any browser: one ``<path>`` holds the
outline and its holes as sub-paths (``fill-rule="evenodd"``), and an
``<animate attributeName="d">`` lists the path data of every frame with
``keyTimes`` from the frame times, ``calcMode="linear"`` and
``repeatCount="indefinite"``. SMIL interpolates path data only between
strings with the same commands in the same order, so every frame writes the
same rings with the same number of points: ``M x,y L x,y … Z`` per ring.

Coordinates: shapes are y up, SVG is y down, so both outputs write
``(x, -y)`` (the same convention as :func:`conformorph.pipelines.shape_io.read_shape`
reading an SVG); ``frames.json`` carries the ``viewBox`` they fit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class AnimationSvgOptions:
    """Options of :func:`animation_svg`.

    Attributes
    ----------
    duration_s : float
        Seconds from the first frame to the last (default 3.0).
    digits : int
        Decimal digits of the coordinates (default 3).
    margin : float
        Space around the shape, as a fraction of its largest extent over all
        frames (default 0.05).
    width_px : int
        Rendered width in pixels; the height follows the aspect ratio
        (default 480).
    fill, stroke : str
        SVG paint of the shape (defaults ``"#4a7bd0"``, ``"#1d3a6e"``).
    stroke_width : float
        Stroke width as a fraction of the largest extent (default 0.004).
    """

    duration_s: float = 3.0
    digits: int = 3
    margin: float = 0.05
    width_px: int = 480
    fill: str = "#4a7bd0"
    stroke: str = "#1d3a6e"
    stroke_width: float = 0.004


def _check_frames(
    frames_rings: list[list[ArrayLike]], frame_times: ArrayLike
) -> tuple[list[list[NDArray[np.float64]]], NDArray[np.float64]]:
    """Frames as float arrays, checked for a consistent ring layout; times as an array."""
    frames = [[np.asarray(r, dtype=np.float64) for r in rings] for rings in frames_rings]
    t = np.asarray(frame_times, dtype=np.float64)
    if not frames:
        raise ValueError("at least one frame is needed")
    if t.shape != (len(frames),):
        raise ValueError(f"frame_times must have shape ({len(frames)},), got {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
        raise ValueError("frame_times must be finite and non-decreasing")
    layout = [r.shape for r in frames[0]]
    for k, rings in enumerate(frames):
        if [r.shape for r in rings] != layout:
            raise ValueError(
                f"frame {k} has rings of shapes {[r.shape for r in rings]}, frame 0 {layout}: "
                "every frame needs the same rings with the same point counts"
            )
        for r in rings:
            if r.ndim != 2 or r.shape[1] != 2 or r.shape[0] < 3 or not np.all(np.isfinite(r)):
                raise ValueError(f"frame {k}: each ring must be a finite (n, 2) array with n >= 3")
    return frames, t


def ring_path_d(ring: ArrayLike, *, digits: int = 3) -> str:
    """SVG path data ``M x,y L x,y … Z`` of one closed ring, y negated.

    Parameters
    ----------
    ring : (n, 2) array_like
        Ring in shape coordinates (y up), last point not repeated.
    digits : int, optional
        Decimal digits.

    Returns
    -------
    str
        One ``M``, ``n - 1`` ``L`` and a ``Z``.

    Examples
    --------
    >>> ring_path_d([[0, 0], [1, 0], [0, 1]], digits=1)
    'M0.0,0.0 L1.0,0.0 L0.0,-1.0 Z'
    """
    P = np.asarray(ring, dtype=np.float64)
    # Python floats format as numpy scalars do, 3× faster; + 0.0: no "-0.0"
    xy = [f"{x + 0.0:.{digits}f},{0.0 - y:.{digits}f}" for x, y in P.tolist()]
    return "M" + " L".join(xy) + " Z"


def _frame_d(rings: list[NDArray[np.float64]], digits: int) -> str:
    return " ".join(ring_path_d(r, digits=digits) for r in rings)


def _view_box(
    frames: list[list[NDArray[np.float64]]], margin: float
) -> tuple[float, float, float, float]:
    """(min x, min y, width, height) in SVG coordinates of all frames, with the margin."""
    pts = np.vstack([r for rings in frames for r in rings]) * [1.0, -1.0]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    extent = float(max((hi - lo).max(), 1e-12))
    pad = margin * extent
    return (
        float(lo[0] - pad),
        float(lo[1] - pad),
        float(hi[0] - lo[0] + 2 * pad),
        float(hi[1] - lo[1] + 2 * pad),
    )


def _key_times(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Frame times mapped onto [0, 1] (evenly spaced if they are all equal)."""
    if len(t) == 1:
        return np.zeros(1)
    span = t[-1] - t[0]
    return (t - t[0]) / span if span > 0 else np.linspace(0.0, 1.0, len(t))


def animation_svg(
    frames_rings: list[list[ArrayLike]],
    frame_times: ArrayLike,
    *,
    options: AnimationSvgOptions | None = None,
) -> str:
    """An SVG document that plays the morph with SMIL ``<animate>``, no script.

    Parameters
    ----------
    frames_rings : list of list of (n_r, 2) array_like
        Per frame, the outer ring then the holes (shape coordinates, y up);
        every frame the same rings with the same point counts.
    frame_times : (f,) array_like
        Morph time of each frame, non-decreasing (e.g. 0 … 1); mapped onto
        ``keyTimes`` in [0, 1].
    options : AnimationSvgOptions, optional

    Returns
    -------
    str
        The SVG document (UTF-8 text). Its static ``d`` is the first frame,
        shown by viewers without SMIL.

    Raises
    ------
    ValueError
        No frames, times of the wrong length or decreasing, or frames whose
        rings differ in number or point counts.
    """
    opts = options or AnimationSvgOptions()
    frames, t = _check_frames(frames_rings, frame_times)
    ds = [_frame_d(rings, opts.digits) for rings in frames]
    x0, y0, w, h = _view_box(frames, opts.margin)
    key_times = ";".join(f"{k:.6f}" for k in _key_times(t))
    height_px = max(1, round(opts.width_px * h / w)) if w > 0 else opts.width_px
    stroke_w = opts.stroke_width * max(w, h)
    animate = ""
    if len(ds) > 1:
        animate = (
            f'\n    <animate attributeName="d" dur="{opts.duration_s:g}s" repeatCount="indefinite" '
            f'calcMode="linear" keyTimes="{key_times}" values={quoteattr(";".join(ds))}/>\n  '
        )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{opts.width_px}" height="{height_px}" '
        f'viewBox="{x0:.{opts.digits}f} {y0:.{opts.digits}f} {w:.{opts.digits}f} {h:.{opts.digits}f}">\n'
        f"  <path fill={quoteattr(opts.fill)} stroke={quoteattr(opts.stroke)} "
        f'stroke-width="{stroke_w:.{opts.digits}g}" stroke-linejoin="round" fill-rule="evenodd" '
        f'd="{ds[0]}">{animate}</path>\n'
        "</svg>\n"
    )


def frames_json(
    frames_rings: list[list[ArrayLike]],
    frame_times: ArrayLike,
    vertices: ArrayLike,
    faces: ArrayLike,
    *,
    digits: int = 6,
) -> dict[str, Any]:
    """Per-frame outline and hole path data and mesh vertices, for a web page.

    Parameters
    ----------
    frames_rings : list of list of (n_r, 2) array_like
        Per frame, the outer ring then the holes (shape coordinates, y up).
    frame_times : (f,) array_like
        Morph time of each frame.
    vertices : (f, n, 2) array_like
        Mesh vertices of each frame (shape coordinates).
    faces : (m, 3) array_like
        Triangles, shared by every frame.
    digits : int, optional
        Decimal digits of coordinates (default 6).

    Returns
    -------
    dict
        ``{"frame_times", "viewBox", "faces", "frames": [{"t", "outline",
        "holes", "vertices"}, …]}``; ``outline`` and each of ``holes`` an
        SVG ``d`` string, ``vertices`` a list of ``[x, -y]``; JSON-ready.

    Raises
    ------
    ValueError
        As :func:`animation_svg`, or vertices/faces of the wrong shape or
        faces out of range.
    """
    frames, t = _check_frames(frames_rings, frame_times)
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces)
    if V.ndim != 3 or V.shape[0] != len(frames) or V.shape[2] != 2:
        raise ValueError(f"vertices must have shape ({len(frames)}, n, 2), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or (F.size and (F.min() < 0 or F.max() >= V.shape[1])):
        raise ValueError(f"faces must be (m, 3) indices below {V.shape[1]}, got shape {F.shape}")
    x0, y0, w, h = _view_box(frames, 0.0)
    out = []
    for k, rings in enumerate(frames):
        out.append(
            {
                "t": float(t[k]),
                "outline": ring_path_d(rings[0], digits=digits),
                "holes": [ring_path_d(r, digits=digits) for r in rings[1:]],
                "vertices": np.round(V[k] * [1.0, -1.0], digits).tolist(),
            }
        )
    return {
        "frame_times": [float(x) for x in t],
        "viewBox": [x0, y0, w, h],
        "faces": F.astype(np.int64).tolist(),
        "frames": out,
    }
