"""Histogram PNGs: a real image whose bars follow the counts."""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from conformorph.pipelines.histogram_png import histogram_png


def test_bars_follow_counts() -> None:
    png = histogram_png([0, 10, 5, 0], [0, 1, 2, 3, 4], "x", width=400, height=200)
    im = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    blue = np.all(im == (52, 101, 164), axis=2)
    cols = blue.sum(axis=0)
    # 10 bins shown at least (empty tail kept up to 10): bin 1 is twice as tall as bin 2
    bw = (400 - 16 - 56) / 4
    c1 = cols[int(56 + 1.5 * bw)]
    c2 = cols[int(56 + 2.5 * bw)]
    assert c1 > 0 and c2 > 0 and abs(c1 / c2 - 2.0) < 0.1
    assert cols[int(56 + 0.5 * bw)] == 0


def test_bad_shapes_are_refused() -> None:
    with pytest.raises(ValueError, match="len"):
        histogram_png([1, 2], [0, 1], "x")
