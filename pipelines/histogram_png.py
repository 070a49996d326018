"""Histogram images (PNG) of the map-quality measures, drawn with Pillow."""

from __future__ import annotations

import io
from collections.abc import Sequence

from PIL import Image, ImageDraw, ImageFont


def histogram_png(
    counts: Sequence[int],
    edges: Sequence[float],
    xlabel: str,
    *,
    width: int = 640,
    height: int = 360,
    max_bars: int = 60,
) -> bytes:
    """A bar chart of a histogram (bars as a percentage of all values) as PNG bytes.

    Empty bins at the top end are dropped (keeping at least ``max_bars``
    bins' worth of range readable); the x axis is labelled with ``xlabel``.
    """
    c = [int(x) for x in counts]
    e = [float(x) for x in edges]
    if len(e) != len(c) + 1 or not c:
        raise ValueError(f"need len(edges) == len(counts) + 1, got {len(e)} and {len(c)}")
    last = max((i for i, x in enumerate(c) if x > 0), default=0)
    n = min(max(last + 1, 10), len(c), max_bars)
    c, e = c[:n], e[: n + 1]
    total = max(sum(int(x) for x in counts), 1)
    pct = [100.0 * x / total for x in c]
    ymax = max(max(pct), 1e-9) * 1.1
    im = Image.new("RGB", (width, height), "white")
    draw = ImageDraw.Draw(im)
    font = ImageFont.load_default()
    left, right, top, bottom = 56, width - 16, 16, height - 44
    bw = (right - left) / n
    for i, p in enumerate(pct):
        h = (bottom - top) * p / ymax
        draw.rectangle(
            [left + i * bw + 1, bottom - h, left + (i + 1) * bw - 1, bottom], fill=(52, 101, 164)
        )
    draw.line([left, bottom, right, bottom], fill="black")
    draw.line([left, top, left, bottom], fill="black")
    for k in range(6):
        t = e[0] + (e[-1] - e[0]) * k / 5
        x = left + (right - left) * k / 5
        draw.line([x, bottom, x, bottom + 4], fill="black")
        draw.text((x - 10, bottom + 6), f"{t:.3g}", fill="black", font=font)
    for frac in (0.0, 0.5, 1.0):
        y = bottom - frac * (bottom - top)
        draw.text((4, y - 6), f"{frac * ymax:.1f}%", fill="black", font=font)
    draw.text((left + 8, bottom + 24), xlabel, fill="black", font=font)
    buf = io.BytesIO()
    im.save(buf, "PNG", optimize=True)
    return buf.getvalue()
