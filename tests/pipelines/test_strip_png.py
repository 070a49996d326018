"""strip.png: the 2D morph's frames as a picture (pipelines/morph2d/strip_png.py)."""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from conformorph.geometry.boundary_loop import boundary_loops
from conformorph.pipelines.morph2d.strip_png import BACKGROUND, FILL, LINE, strip_png

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
SQUARE_F = np.array([[0, 1, 2], [0, 2, 3]])


def _image(data: bytes) -> Image.Image:
    image = Image.open(io.BytesIO(data))
    image.load()
    return image


def test_a_square_growing_into_a_wide_rectangle_by_hand() -> None:
    """Two frames: the unit square, then the 2 x 1 rectangle. 101 px tall frames (scale
    100 px per unit), panel 201 px wide, gap 15, margin 7: a 7 + 201 + 15 + 201 + 7 wide,
    7 + 101 + 7 tall picture; inside the square filled, right of it (in panel 0)
    background, the rectangle's far half filled, its outline drawn."""
    frames = np.stack([SQUARE, SQUARE * [2.0, 1.0]])
    image = _image(strip_png(frames, SQUARE_F, boundary_loops(SQUARE_F), height=101))
    assert image.size == (7 + 201 + 15 + 201 + 7, 7 + 101 + 7)
    px = image.convert("RGB").load()
    assert px[7 + 50, 7 + 50] == FILL  # inside the square
    assert px[7 + 150, 7 + 50] == BACKGROUND  # beyond the square, panel 0
    assert px[7 + 201 + 15 + 150, 7 + 50] == FILL  # the rectangle's far half
    assert px[7 + 201 + 15 + 100, 7] == LINE  # its top edge (y up: row 7 is y = 1)


def test_count_picks_evenly_spaced_frames_and_inputs_are_checked() -> None:
    t = np.linspace(0.0, 1.0, 11)[:, None, None]
    frames = SQUARE[None] * (1.0 + t)
    one = _image(strip_png(frames, SQUARE_F, boundary_loops(SQUARE_F), count=1, height=50))
    six = _image(strip_png(frames, SQUARE_F, boundary_loops(SQUARE_F), count=6, height=50))
    assert six.size[0] > 5 * one.size[0]
    with pytest.raises(ValueError, match="finite"):
        strip_png(np.full((2, 4, 2), np.nan), SQUARE_F, [])
    with pytest.raises(ValueError, match="count"):
        strip_png(frames, SQUARE_F, [], count=0)
