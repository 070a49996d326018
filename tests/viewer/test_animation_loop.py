"""``animation.svg``'s ``loop`` modes play as documented in headless Chromium (issues 28, 29).

The web outputs of a two-part mesh (a triangle and a square, moving at constant
speed) are written with each ``loop``; the browser's SMIL clock is paused and
seeked, and each ``<path>``'s animated geometry (its computed ``d``) compared with
the frames' linear blend at that time: ``once`` plays the frames in ``dur`` and
then holds the last (``fill="freeze"``); ``repeat`` starts again from the first;
``alternate`` goes back to the first in a second ``dur`` and starts again.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conformorph.pipelines.morph2d import FPS, write_web_outputs

pytestmark = pytest.mark.timeout(120)
SVG = "{http://www.w3.org/2000/svg}"
COUNT = 5


def _frames() -> tuple[np.ndarray, np.ndarray]:
    """(COUNT, 7, 2) frames: a triangle and a square, each moving right 1 unit a frame."""
    tri = [[0, 0], [1, 0], [0, 1]]
    square = [[3, 0], [4, 0], [4, 1], [3, 1]]
    V = np.array(tri + square, dtype=float)
    F = np.array([[0, 1, 2], [3, 4, 5], [3, 5, 6]])
    return np.array([V + [k, 0.5 * k] for k in range(COUNT)]), F


def _position(loop: str, s: float) -> float:
    """Where in the frames (0 … COUNT − 1) each mode is at s durations from the start."""
    last = COUNT - 1
    if loop == "once":
        return last * min(s, 1.0)
    if loop == "repeat":
        return last * (s % 1.0)
    phase = s % 2.0
    return last * (phase if phase <= 1.0 else 2.0 - phase)


def _drawn(page: Any, t: float) -> list[np.ndarray]:
    ds = page.evaluate(
        """t => { const s = document.documentElement; s.pauseAnimations(); s.setCurrentTime(t);
                  return Array.from(document.querySelectorAll('path'))
                              .map(p => getComputedStyle(p).d); }""",
        t,
    )
    return [np.array([float(x) for x in re.findall(r"-?[\d.]+(?:e-?\d+)?", d)]) for d in ds]


@pytest.mark.parametrize("loop", ["once", "repeat", "alternate"])
def test_loop_modes_play_as_documented(browser: Any, tmp_path: Path, loop: str) -> None:
    X, F = _frames()
    write_web_outputs(tmp_path, X, F, np.linspace(0.0, 1.0, COUNT), loop=loop)
    root = ET.parse(tmp_path / "animation.svg").getroot()
    animates = list(root.iter(SVG + "animate"))
    assert len(animates) == 2 and all(a.get("fill") == "freeze" for a in animates)
    dur = (COUNT - 1) / FPS  # one pass, as animation.glb plays
    context = browser.new_context(viewport={"width": 300, "height": 200})
    try:
        page = context.new_page()
        page.goto((tmp_path / "animation.svg").as_uri())
        for s in (0.0, 0.3, 0.7, 1.4, 1.8, 2.3, 3.6):
            pos = _position(loop, s)
            k = min(int(pos), COUNT - 2)
            Y = X[k] + (pos - k) * (X[k + 1] - X[k])  # linear between frames
            parts = [Y[:3], Y[3:]]
            drawn = _drawn(page, s * dur)
            assert len(drawn) == 2
            for p, (got, want) in enumerate(zip(drawn, parts, strict=True)):
                # the part's ring, drawn as (x, -y) from some starting vertex
                pts = got.reshape(-1, 2) * [1, -1]
                assert pts.shape == want.shape, (loop, s, p)
                gap = np.linalg.norm(pts[:, None] - want[None], axis=2)
                assert np.all(gap.min(axis=1) < 1e-3) and np.all(gap.min(axis=0) < 1e-3), (
                    f"{loop} at {s} durations, part {p}: {pts.tolist()} != {want.tolist()}"
                )
    finally:
        context.close()
