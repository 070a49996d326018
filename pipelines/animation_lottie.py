"""Lottie output of a 2D morph: ``animation.json``, the Bodymovin format.

The format After Effects exports through Bodymovin and that lottie-web,
LottieFiles and the iOS/Android Lottie players play. The document:

* ``v`` (format version), ``fr`` (frames per second), ``ip`` = 0 and ``op`` =
  the number of frames (a layer shows frames ``ip`` ≤ f < ``op``), ``w`` and
  ``h`` the canvas in pixels;
* one shape layer (``ty`` 4) per part, the first part on top, each holding
  one group (``ty`` "gr") of one path (``ty`` "sh") per ring, the outer ring
  first then the holes, an even-odd fill (``ty`` "fl", ``r`` 2: a hole is a
  hole whatever its orientation) and the group's identity transform;
* each path keyframed (``ks.a`` 1) at every frame k = 0 … T−1: vertices ``v``,
  tangents ``i`` / ``o`` zero (straight segments, as ``frames.json``), ``c``
  true. Between frames the players interpolate linearly (easing handles
  (0, 0) and (1, 1), the identity) or hold the frame (``h`` 1).

Coordinates: the Lottie canvas has its origin at the top left and y down,
so a shape point (x, y) (y up) is written at (x − x₀, −y − y₀), where
(x₀, y₀) is the top-left corner of the box around every frame with a margin,
the same box as ``animation.svg``'s ``viewBox``, widened to whole pixels
(one shape unit is one pixel: an icon drawn in a 24-unit ``viewBox`` gives a
canvas of about 24 px, which players scale to their container).

Precision: coordinates are rounded to 1e-6 of the frames' largest extent, far
below what a screen shows and below the 1e-3 that the lottie-web check
(``tests/viewer/test_lottie_plays.py``) allows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from conformorph.pipelines.animation_svg import check_frame_parts, view_box

#: The Bodymovin format version written (lottie-web 5.7 onwards reads it unchanged).
LOTTIE_VERSION = "5.7.4"


@dataclass(frozen=True)
class LottieOptions:
    """Options of :func:`lottie_animation`.

    Attributes
    ----------
    fps : float
        Frames per second (``fr``; default 30, as ``animation.glb``).
    hold : bool
        Hold each frame until the next instead of interpolating linearly
        between them (default False).
    margin : float
        Space around the shape, as a fraction of its largest extent over all
        frames (default 0.05, as ``animation.svg``).
    fill : tuple of float
        RGB fill colour in [0, 1] (default ``#4a7bd0``, as ``animation.svg``).
    name : str
        The composition's name (``nm``).
    """

    fps: float = 30.0
    hold: bool = False
    margin: float = 0.05
    fill: tuple[float, float, float] = (0x4A / 255, 0x7B / 255, 0xD0 / 255)
    name: str = "morph2d"


def _static(value: Any) -> dict[str, Any]:
    """A property that does not animate."""
    return {"a": 0, "k": value}


def _ring_shape(ring: NDArray[np.float64], digits: int) -> dict[str, Any]:
    """A closed Lottie path of straight segments through the ring's points (canvas coords)."""
    v = np.round(ring, digits).tolist()
    zero = [[0, 0]] * len(v)
    return {"c": True, "v": v, "i": zero, "o": zero}


def _ring_keyframes(rings: list[NDArray[np.float64]], digits: int, hold: bool) -> dict[str, Any]:
    """The ``ks`` of a path: a keyframe per frame, or a static path for one frame."""
    if len(rings) == 1:
        return _static(_ring_shape(rings[0], digits))
    keys: list[dict[str, Any]] = []
    for k, ring in enumerate(rings):
        key: dict[str, Any] = {"t": k, "s": [_ring_shape(ring, digits)]}
        if k < len(rings) - 1:
            if hold:
                key["h"] = 1
            else:  # easing handles (0, 0), (1, 1): the identity, i.e. linear
                key["o"] = {"x": 0, "y": 0}
                key["i"] = {"x": 1, "y": 1}
        keys.append(key)
    return {"a": 1, "k": keys}


def _group_transform() -> dict[str, Any]:
    return {
        "ty": "tr",
        "p": _static([0, 0]),
        "a": _static([0, 0]),
        "s": _static([100, 100]),
        "r": _static(0),
        "o": _static(100),
        "sk": _static(0),
        "sa": _static(0),
        "nm": "Transform",
    }


def _part_layer(
    part_frames: list[list[NDArray[np.float64]]],
    index: int,
    digits: int,
    opts: LottieOptions,
) -> dict[str, Any]:
    """The shape layer of one part: per ring a keyframed path, an even-odd fill."""
    count = len(part_frames)
    paths = [
        {
            "ty": "sh",
            "ind": r,
            "nm": "outline" if r == 0 else f"hole {r}",
            "ks": _ring_keyframes([rings[r] for rings in part_frames], digits, opts.hold),
        }
        for r in range(len(part_frames[0]))
    ]
    fill = {
        "ty": "fl",
        "nm": "Fill",
        "c": _static([*opts.fill, 1]),
        "o": _static(100),
        "r": 2,
    }
    return {
        "ddd": 0,
        "ind": index + 1,
        "ty": 4,
        "nm": f"part {index}",
        "sr": 1,
        "ks": {
            "o": _static(100),
            "r": _static(0),
            "p": _static([0, 0, 0]),
            "a": _static([0, 0, 0]),
            "s": _static([100, 100, 100]),
        },
        "ao": 0,
        "shapes": [
            {
                "ty": "gr",
                "nm": f"part {index}",
                "np": len(paths) + 1,
                "it": [*paths, fill, _group_transform()],
            }
        ],
        "ip": 0,
        "op": count,
        "st": 0,
        "bm": 0,
    }


def lottie_animation(
    frames_parts: list[list[list[ArrayLike]]],
    *,
    options: LottieOptions | None = None,
) -> dict[str, Any]:
    """A Lottie (Bodymovin JSON) document playing the frames at ``fps``.

    Parameters
    ----------
    frames_parts : list of list of list of (n_r, 2) array_like
        Per frame, per part, its outer ring then its holes (shape coordinates,
        y up); every frame the same parts with the same rings and point counts.
        Frame k is shown at Lottie frame k.
    options : LottieOptions, optional

    Returns
    -------
    dict
        The document, JSON-ready (``json.dumps``): ``v``, ``fr``, ``ip``,
        ``op``, ``w``, ``h``, ``nm``, ``ddd``, ``assets`` (empty), ``layers``
        (one per part) and ``meta.canvas_origin``, the shape point (x₀, −y₀)
        placed at the canvas's top-left corner.

    Raises
    ------
    ValueError
        As :func:`conformorph.pipelines.animation_svg.check_frame_parts`, or a
        frame rate that is not positive.
    """
    opts = options or LottieOptions()
    if not (math.isfinite(opts.fps) and opts.fps > 0):
        raise ValueError(f"fps must be a positive number, got {opts.fps}")
    frames, _ = check_frame_parts(frames_parts, np.arange(len(frames_parts), dtype=np.float64))
    x0, y0, w, h = view_box(frames, opts.margin)
    width, height = max(1, math.ceil(w)), max(1, math.ceil(h))
    # centre the box on the whole-pixel canvas
    x0 -= (width - w) / 2.0
    y0 -= (height - h) / 2.0
    extent = max(w, h) / (1.0 + 2.0 * opts.margin)
    digits = max(0, 6 - math.floor(math.log10(max(extent, 1e-300))))
    to_canvas = np.array([x0, y0])
    canvas = [[[r * [1.0, -1.0] - to_canvas for r in part] for part in parts] for parts in frames]
    count = len(canvas)
    layers = [
        _part_layer([parts[p] for parts in canvas], p, digits, opts) for p in range(len(canvas[0]))
    ]
    return {
        "v": LOTTIE_VERSION,
        "fr": opts.fps,
        "ip": 0,
        "op": count,
        "w": width,
        "h": height,
        "nm": opts.name,
        "ddd": 0,
        "assets": [],
        "layers": layers,
        "meta": {"g": "conformorph", "canvas_origin": [x0, -y0]},
    }
