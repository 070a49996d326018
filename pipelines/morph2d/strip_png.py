"""``strip.png``: a raster strip of a 2D morph's frames, for a glance without an SVG viewer.

The same frames as ``strip.svg`` (:data:`~conformorph.pipelines.morph2d.outputs.STRIP_FRAMES`
evenly spaced, y up), each frame's triangles filled and its boundary loops (outlines and
holes) drawn over them, so a part crossing another or a hole leaving its outline shows as
crossing lines. Drawn with Pillow, one frame every ``height`` pixels tall.
"""

from __future__ import annotations

import io

import numpy as np
from numpy.typing import NDArray

#: fill and outline colours (those of ``strip.svg``) and the background
FILL, LINE, BACKGROUND = (207, 227, 245), (42, 93, 138), (255, 255, 255)


def strip_png(
    frames: NDArray[np.float64],
    F: NDArray[np.int64],
    loops: list[NDArray[np.int64]],
    *,
    count: int = 6,
    height: int = 200,
) -> bytes:
    """PNG bytes of ``count`` evenly spaced frames side by side.

    Parameters
    ----------
    frames : (T, n, 2) float64
        Frame positions (y up).
    F : (m, 3) int64
        Triangles shared by every frame.
    loops : list of (k_r,) int64
        The mesh's boundary loops (vertex indices), drawn as closed lines.
    count : int, optional
        Frames drawn (at most T).
    height : int, optional
        Pixels for the frames' common height (the width follows their aspect).

    Returns
    -------
    bytes
        An RGB PNG, ``count`` panels separated by 15 % of the height.
    """
    from PIL import Image, ImageDraw

    frames = np.asarray(frames, dtype=np.float64)
    if frames.ndim != 3 or frames.shape[2] != 2 or not np.all(np.isfinite(frames)):
        raise ValueError(f"frames must be finite (T, n, 2), got {frames.shape}")
    if count < 1 or height < 8:
        raise ValueError(f"count must be >= 1 and height >= 8, got {count} and {height}")
    T = frames.shape[0]
    pick = np.unique(np.round(np.linspace(0, T - 1, min(count, T))).astype(int))
    lo = frames.reshape(-1, 2).min(axis=0)
    w, h = frames.reshape(-1, 2).max(axis=0) - lo
    scale = (height - 1) / max(h, w * 1e-3, 1e-300)
    panel, gap = int(np.ceil(w * scale)) + 1, int(0.15 * height)
    margin = gap // 2
    image = Image.new(
        "RGB", (len(pick) * panel + (len(pick) - 1) * gap + 2 * margin, height + 2 * margin),
        BACKGROUND,
    )  # fmt: skip
    draw = ImageDraw.Draw(image)
    line = max(1, height // 100)
    for j, k in enumerate(pick):
        X = (frames[k] - lo) * scale
        P = np.c_[X[:, 0] + margin + j * (panel + gap), margin + (height - 1) - X[:, 1]]
        for tri in P[F].tolist():
            draw.polygon([tuple(c) for c in tri], fill=FILL)
        for loop in loops:
            ring = [tuple(c) for c in P[np.r_[loop, loop[:1]]].tolist()]
            draw.line(ring, fill=LINE, width=line, joint="curve")
    out = io.BytesIO()
    image.save(out, format="PNG", optimize=True)
    return out.getvalue()
