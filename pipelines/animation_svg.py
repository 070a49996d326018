"""Web outputs of a 2D morph: ``animation.svg`` (SMIL, no script) and ``frames.json``.

A frame is a list of parts, a part a list of rings: its outer ring, then its
holes (``frames_parts[k][p][r]``, an ``(n, 2)`` array). ``animation.svg``
plays the morph in any browser: one ``<path>`` per part holds its outer ring
and holes as sub-paths (``fill-rule="evenodd"``: a hole is a hole whatever
its orientation), and an ``<animate attributeName="d">`` lists the part's
path data of every frame with ``keyTimes`` from the frame times and
``calcMode="linear"``. How it plays is ``loop`` (:mod:`conformorph.pipelines.animation_loop`):
once and hold the last frame (``fill="freeze"``, the default), repeated, or
there and back (the values and ``keyTimes`` mirrored over twice the
duration). SMIL interpolates path data only between strings with the same
commands in the same order, so every frame writes the same rings with the
same number of points: ``M x,y L x,y … Z`` per ring.

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

from conformorph.pipelines.animation_loop import DEFAULT_LOOP, check_loop

#: Per frame, per part, per ring an ``(n, 2)`` array (outer ring first, then holes).
FrameParts = list[list[list[NDArray[np.float64]]]]


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
    loop : {"once", "repeat", "alternate"}
        How the animation plays (default ``"once"``, holding the last frame;
        :mod:`conformorph.pipelines.animation_loop`).
    """

    duration_s: float = 3.0
    digits: int = 3
    margin: float = 0.05
    width_px: int = 480
    fill: str = "#4a7bd0"
    stroke: str = "#1d3a6e"
    stroke_width: float = 0.004
    loop: str = DEFAULT_LOOP


def check_frame_parts(
    frames_parts: list[list[list[ArrayLike]]], frame_times: ArrayLike
) -> tuple[FrameParts, NDArray[np.float64]]:
    """Frames as float arrays, checked for one part and ring layout; times as an array.

    Parameters
    ----------
    frames_parts : list of list of list of (n_r, 2) array_like
        Per frame, per part, its outer ring then its holes (shape coordinates,
        y up).
    frame_times : (f,) array_like
        Morph time of each frame, finite and non-decreasing.

    Returns
    -------
    frames : list of list of list of (n_r, 2) float64
    times : (f,) float64

    Raises
    ------
    ValueError
        No frames, a frame without parts or a part without rings, times of the
        wrong length or decreasing, frames whose parts or rings differ in number
        or point counts, a ring with fewer than 3 points or a non-finite value.
    """
    frames = [
        [[np.asarray(r, dtype=np.float64) for r in part] for part in parts]
        for parts in frames_parts
    ]
    t = np.asarray(frame_times, dtype=np.float64)
    if not frames:
        raise ValueError("at least one frame is needed")
    if t.shape != (len(frames),):
        raise ValueError(f"frame_times must have shape ({len(frames)},), got {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
        raise ValueError("frame_times must be finite and non-decreasing")
    layout = [[r.shape for r in part] for part in frames[0]]
    if not layout or not all(layout):
        raise ValueError("every frame needs at least one part, and every part a ring")
    for k, parts in enumerate(frames):
        if [[r.shape for r in part] for part in parts] != layout:
            raise ValueError(
                f"frame {k} has parts with rings of shapes "
                f"{[[r.shape for r in part] for part in parts]}, frame 0 {layout}: every frame "
                "needs the same parts with the same rings and point counts"
            )
        for part in parts:
            for r in part:
                if r.ndim != 2 or r.shape[1] != 2 or r.shape[0] < 3 or not np.all(np.isfinite(r)):
                    raise ValueError(
                        f"frame {k}: each ring must be a finite (n, 2) array with n >= 3"
                    )
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


def view_box(frames: FrameParts, margin: float) -> tuple[float, float, float, float]:
    """The box around every frame in SVG coordinates (y down), with a margin.

    Parameters
    ----------
    frames : list of list of list of (n_r, 2) float64
        Per frame, per part, its rings (shape coordinates, y up).
    margin : float
        Space added on each side, as a fraction of the largest extent.

    Returns
    -------
    tuple of float
        ``(min x, min y, width, height)``.
    """
    pts = np.vstack([r for parts in frames for part in parts for r in part]) * [1.0, -1.0]
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


def _smil_timing(
    ds: list[str], key_times: NDArray[np.float64], duration_s: float, loop: str
) -> tuple[list[str], NDArray[np.float64], float, str]:
    """Values, key times, duration and repeat attributes of one ``<animate>`` for ``loop``.

    ``alternate`` plays the frames forwards then backwards in twice the
    duration: values ``d_0 … d_n … d_0`` and key times ``k_i / 2`` then
    ``1 − k_i / 2`` (mirrored), so the way back retraces the way there.
    """
    if loop == "alternate":
        back = 1.0 - key_times[-2::-1] / 2.0
        return ds + ds[-2::-1], np.r_[key_times / 2.0, back], 2.0 * duration_s, "indefinite"
    return ds, key_times, duration_s, "indefinite" if loop == "repeat" else "1"


def _part_element(
    ds: list[str], key_times: NDArray[np.float64], paint: str, opts: AnimationSvgOptions
) -> str:
    """One part's ``<path>`` (first frame's ``d``) with its ``<animate>``."""
    animate = ""
    if len(ds) > 1:
        values, keys, dur, repeat = _smil_timing(ds, key_times, opts.duration_s, opts.loop)
        key_text = ";".join(f"{k:.6f}" for k in keys)
        animate = (
            f'\n    <animate attributeName="d" dur="{dur:g}s" repeatCount="{repeat}" '
            f'fill="freeze" calcMode="linear" keyTimes="{key_text}" '
            f"values={quoteattr(';'.join(values))}/>\n  "
        )
    return f'  <path {paint} d="{ds[0]}">{animate}</path>\n'


def animation_svg(
    frames_parts: list[list[list[ArrayLike]]],
    frame_times: ArrayLike,
    *,
    options: AnimationSvgOptions | None = None,
) -> str:
    """An SVG document that plays the morph with SMIL ``<animate>``, no script.

    Parameters
    ----------
    frames_parts : list of list of list of (n_r, 2) array_like
        Per frame, per part, its outer ring then its holes (shape coordinates,
        y up); every frame the same parts with the same rings and point counts.
    frame_times : (f,) array_like
        Morph time of each frame, non-decreasing (e.g. 0 … 1); mapped onto
        ``keyTimes`` in [0, 1].
    options : AnimationSvgOptions, optional

    Returns
    -------
    str
        The SVG document (UTF-8 text): one ``<path>`` per part, in order. Each
        static ``d`` is the first frame, shown by viewers without SMIL.

    Raises
    ------
    ValueError
        No frames, times of the wrong length or decreasing, frames whose parts
        or rings differ in number or point counts, or an unknown ``loop``.
    """
    opts = options or AnimationSvgOptions()
    check_loop(opts.loop)
    frames, t = check_frame_parts(frames_parts, frame_times)
    x0, y0, w, h = view_box(frames, opts.margin)
    key_times = _key_times(t)
    height_px = max(1, round(opts.width_px * h / w)) if w > 0 else opts.width_px
    stroke_w = opts.stroke_width * max(w, h)
    paint = (
        f"fill={quoteattr(opts.fill)} stroke={quoteattr(opts.stroke)} "
        f'stroke-width="{stroke_w:.{opts.digits}g}" stroke-linejoin="round" fill-rule="evenodd"'
    )
    paths = "".join(
        _part_element([_frame_d(parts[p], opts.digits) for parts in frames], key_times, paint, opts)
        for p in range(len(frames[0]))
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{opts.width_px}" height="{height_px}" '
        f'viewBox="{x0:.{opts.digits}f} {y0:.{opts.digits}f} {w:.{opts.digits}f} {h:.{opts.digits}f}">\n'
        + paths
        + "</svg>\n"
    )


def frames_json(
    frames_parts: list[list[list[ArrayLike]]],
    frame_times: ArrayLike,
    vertices: ArrayLike,
    faces: ArrayLike,
    *,
    digits: int = 6,
) -> dict[str, Any]:
    """Per-frame path data of every part and the mesh vertices, for a web page.

    Parameters
    ----------
    frames_parts : list of list of list of (n_r, 2) array_like
        Per frame, per part, its outer ring then its holes (shape coordinates,
        y up).
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
        "holes", "parts", "vertices"}, …]}``; ``parts`` a list of
        ``{"outline", "holes"}`` per part, ``outline`` and each of ``holes``
        an SVG ``d`` string; ``outline`` and ``holes`` of the frame itself are
        the first part's (the layout before shapes had several parts);
        ``vertices`` a list of ``[x, -y]``; JSON-ready.

    Raises
    ------
    ValueError
        As :func:`animation_svg`, or vertices/faces of the wrong shape or
        faces out of range.
    """
    frames, t = check_frame_parts(frames_parts, frame_times)
    V = np.asarray(vertices, dtype=np.float64)
    F = np.asarray(faces)
    if V.ndim != 3 or V.shape[0] != len(frames) or V.shape[2] != 2:
        raise ValueError(f"vertices must have shape ({len(frames)}, n, 2), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or (F.size and (F.min() < 0 or F.max() >= V.shape[1])):
        raise ValueError(f"faces must be (m, 3) indices below {V.shape[1]}, got shape {F.shape}")
    x0, y0, w, h = view_box(frames, 0.0)
    out = []
    for k, parts in enumerate(frames):
        paths = [
            {
                "outline": ring_path_d(part[0], digits=digits),
                "holes": [ring_path_d(r, digits=digits) for r in part[1:]],
            }
            for part in parts
        ]
        out.append(
            {
                "t": float(t[k]),
                **paths[0],
                "parts": paths,
                "vertices": np.round(V[k] * [1.0, -1.0], digits).tolist(),
            }
        )
    return {
        "frame_times": [float(x) for x in t],
        "viewBox": [x0, y0, w, h],
        "faces": F.astype(np.int64).tolist(),
        "frames": out,
    }
