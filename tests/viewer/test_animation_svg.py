"""``animation.svg`` of a real 2D morph plays in headless Chromium (issue 18).

A ``conformorph morph2d`` run without anchors writes ``animation.svg`` and
``frames.json``. The browser opens the SVG, its SMIL clock runs; the clock is
then paused and seeked (``pauseAnimations`` / ``setCurrentTime``) to frame 0
and to a middle frame, and each screenshot is compared with a static SVG of
that frame's outline and holes taken from ``frames.json`` (same canvas, same
paint, no ``<animate>``), rendered by the same browser.
"""

from __future__ import annotations

import io
import json
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conformorph.cli.main import main

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
SVG_NS = "http://www.w3.org/2000/svg"

pytestmark = pytest.mark.timeout(240)


@pytest.fixture(scope="module")
def morph_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("anim") / "out"
    src, tgt = SHAPES / "dejavu_bold_I.json", SHAPES / "dejavu_bold_L.json"
    rc = main(["morph2d", str(src), str(tgt), "--frames", "12", "-o", str(out), "--quiet"])
    assert rc == 0
    return out


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def _differing(a: np.ndarray, b: np.ndarray) -> float:
    """Fraction of pixels whose colour differs by more than 64 in some channel."""
    assert a.shape == b.shape
    return float(np.mean(np.abs(a - b).max(axis=2) > 64))


def _static_frame(animation: str, frame: dict[str, Any]) -> str:
    """The animation's document with its path set to one frame of frames.json, no <animate>."""
    ET.register_namespace("", SVG_NS)
    root = ET.fromstring(animation)
    path = root.find(f"{{{SVG_NS}}}path")
    assert path is not None
    for child in list(path):
        path.remove(child)
    path.set("d", " ".join([frame["outline"], *frame["holes"]]))
    return ET.tostring(root, encoding="unicode")


def _shot(page: Any, url: str, seek: float | None = None) -> np.ndarray:
    page.goto(url)
    if seek is not None:
        page.evaluate(
            "t => { const s = document.documentElement; s.pauseAnimations(); s.setCurrentTime(t); }",
            seek,
        )
    # two animation frames: the seeked value is rendered before the screenshot
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    png: bytes = page.screenshot()
    return _pixels(png)


def test_animation_svg_plays_and_starts_at_frame_0(
    browser: Any, morph_dir: Path, tmp_path: Path
) -> None:
    text = (morph_dir / "animation.svg").read_text()
    frames = json.loads((morph_dir / "frames.json").read_text())["frames"]
    root = ET.fromstring(text)
    width, height = int(root.get("width", "0")), int(root.get("height", "0"))
    animate = root.find(f"{{{SVG_NS}}}path/{{{SVG_NS}}}animate")
    assert animate is not None and width > 0 and height > 0
    dur = float(animate.get("dur", "").removesuffix("s"))
    key_times = [float(k) for k in animate.get("keyTimes", "").split(";")]
    assert len(key_times) == len(frames) == 12
    mid = 6
    statics = {}
    for k in (0, mid):
        p = tmp_path / f"frame{k}.svg"
        p.write_text(_static_frame(text, frames[k]))
        statics[k] = p.as_uri()

    context = browser.new_context(viewport={"width": width, "height": height})
    try:
        page = context.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        url = (morph_dir / "animation.svg").as_uri()
        page.goto(url)
        # the SMIL clock runs on its own (no script in the file)
        t0 = page.evaluate("document.documentElement.getCurrentTime()")
        page.wait_for_timeout(250)
        t1 = page.evaluate("document.documentElement.getCurrentTime()")
        assert t1 > t0 and not page.evaluate("document.documentElement.animationsPaused()")
        first = _shot(page, url, seek=0.0)
        middle = _shot(page, url, seek=key_times[mid] * dur)
        ref0 = _shot(page, statics[0])
        ref_mid = _shot(page, statics[mid])
        assert not errors, errors
    finally:
        context.close()

    background = first[1, 1]
    assert np.mean(np.abs(first - background).max(axis=2) > 64) > 0.05  # the shape is drawn
    # the two times differ, and the frame-0 and middle-frame references differ as much
    assert _differing(first, middle) > 0.02
    assert _differing(ref0, ref_mid) > 0.02
    # the first screenshot is frame 0 of frames.json, the middle one its frame 6
    assert _differing(first, ref0) < 0.002
    assert _differing(middle, ref_mid) < 0.002
