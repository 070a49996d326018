"""``animation.json`` (Lottie) of a real 2D morph plays in lottie-web in headless Chromium.

A ``conformorph morph2d`` run writes ``animation.json`` and ``frames.json``.
lottie-web (npm, the version ``package.json`` pins; from ``node_modules`` or,
when the repository's ``node_modules`` lacks it, installed by npm into a
temporary folder) loads the animation with its SVG renderer; at every frame
(``goToAndStop(k, true)``) the path data it draws (each part's ``<path d>``:
the outer ring and holes as sub-paths of cubic segments) must be that frame's
rings in ``frames.json`` to within 1e-3 of the shape's size. Between two
frames it must draw their linear blend (the keyframes interpolate linearly).

Skips, saying why, when chromium, Playwright, or both ``node_modules/lottie-web``
and a working npm are missing.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conformorph.cli.main import main
from conformorph.pipelines.morph2d import write_web_outputs
from tests.npm_package import npm_package

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
BUILD = Path("build") / "player" / "lottie_svg.min.js"

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def lottie_js(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """lottie-web's SVG player script, at the version package.json pins."""
    return npm_package("lottie-web", tmp_path_factory) / BUILD


def _morph(out: Path, src: str, tgt: str, frames: int) -> Path:
    rc = main(
        ["morph2d", str(SHAPES / src), str(SHAPES / tgt), "--frames", str(frames)]
        + ["-o", str(out), "--quiet"]
    )
    assert rc == 0
    return out


def _two_parts(out: Path, frames: int) -> Path:
    """The web outputs of a mesh of two parts: a square annulus growing and turning, and
    a triangle moving right (the layout the several-part morph hands the writers)."""
    outer = [[0, 0], [3, 0], [3, 3], [0, 3]]
    inner = [[1, 1], [2, 1], [2, 2], [1, 2]]
    F = [[i, (i + 1) % 4, 4 + (i + 1) % 4] for i in range(4)]
    F += [[i, 4 + (i + 1) % 4, 4 + i] for i in range(4)]
    V = np.array(outer + inner + [[5, 0], [6, 0], [5.5, 1]], dtype=float)
    t = np.linspace(0.0, 1.0, frames)
    X = []
    for s in t:
        c, n = np.cos(0.5 * s), np.sin(0.5 * s)
        Y = V.copy()
        Y[:8] = (1 + s) * V[:8] @ np.array([[c, n], [-n, c]])
        Y[8:] += [2 * s, 0]
        X.append(Y)
    write_web_outputs(out, np.array(X), np.array(F + [[8, 9, 10]]), t)
    return out


@pytest.fixture(scope="module")
def morphs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    base = tmp_path_factory.mktemp("lottie")
    return [
        # two parts, one with a hole
        _two_parts(base / "two_parts", 6),
        # one outline each
        _morph(base / "heart_star", "flubber_heart.json", "flubber_star.json", 9),
        # an outline with a hole
        _morph(base / "annulus", "annulus_round.json", "annulus_square.json", 7),
    ]


def _ring_points(d: str) -> list[np.ndarray]:
    """The vertices of each closed sub-path of lottie-web's ``M p C a b p … C a b p0 z`` data."""
    rings = []
    for sub in re.findall(r"M[^M]*", d):
        nums = np.array([float(x) for x in re.findall(r"-?[\d.]+(?:e-?\d+)?", sub)])
        pts = nums.reshape(-1, 2)
        # M's point, then each C's end point; the closing C ends on the first point
        ends = np.vstack([pts[:1], pts[1:][2::3]])
        assert np.allclose(ends[-1], ends[0]), "a ring must close on its first point"
        rings.append(ends[:-1])
    return rings


def _frames_json_rings(frame: dict[str, Any]) -> list[list[np.ndarray]]:
    """Per part, its rings in SVG coordinates (y down), from one frame of frames.json."""
    parts = frame.get("parts") or [{"outline": frame["outline"], "holes": frame["holes"]}]
    out = []
    for part in parts:
        rings = []
        for d in [part["outline"], *part["holes"]]:
            nums = [float(x) for x in re.findall(r"-?[\d.]+(?:e-?\d+)?", d)]
            rings.append(np.array(nums).reshape(-1, 2))
        out.append(rings)
    return out


PLAY = """async ([data, frames]) => {
  const box = document.getElementById('anim');
  const anim = lottie.loadAnimation({container: box, renderer: 'svg', loop: false,
                                     autoplay: false, animationData: data});
  await new Promise(r => anim.isLoaded ? r() : anim.addEventListener('DOMLoaded', r));
  const out = [];
  for (const f of frames) {
    anim.goToAndStop(f, true);
    const parts = data.layers.map(l => {
      const g = box.querySelector('#' + l.ln);
      return Array.from(g.querySelectorAll('path')).map(p => p.getAttribute('d'));
    });
    out.push(parts);
  }
  return {frames: out, total: anim.totalFrames};
}"""


def test_lottie_web_draws_frames_json_at_every_frame(
    browser: Any, morphs: list[Path], lottie_js: Path
) -> None:
    context = browser.new_context(viewport={"width": 400, "height": 400})
    try:
        page = context.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        for out in morphs:
            data = json.loads((out / "animation.json").read_text())
            doc = json.loads((out / "frames.json").read_text())
            expected = [_frames_json_rings(fr) for fr in doc["frames"]]
            count = len(expected)
            size = max(doc["viewBox"][2], doc["viewBox"][3])
            ox, oy_top = data["meta"]["canvas_origin"]  # canvas = (x - ox, -y + oy_top)
            to_canvas = np.array([-ox, oy_top])
            for k, layer in enumerate(data["layers"]):
                layer["ln"] = f"part{k}"  # an id on each layer's <g>, to find it
            page.set_content('<div id="anim" style="width:400px;height:400px"></div>')
            page.add_script_tag(path=str(lottie_js))
            wanted = [*range(count), 2.5]
            got = page.evaluate(PLAY, [data, wanted])
            assert got["total"] == data["op"] == count
            assert len(got["frames"][0]) == len(expected[0]) == len(data["layers"]) >= 1
            for k, parts in zip(wanted, got["frames"], strict=True):
                if k == 2.5:  # between frames 2 and 3: their linear blend
                    ref = [
                        [(a + b) / 2 for a, b in zip(pa, pb, strict=True)]
                        for pa, pb in zip(expected[2], expected[3], strict=True)
                    ]
                else:
                    ref = expected[int(k)]
                for p, (ds, rings) in enumerate(zip(parts, ref, strict=True)):
                    assert len(ds) == 1, f"part {p}: one filled path, got {len(ds)}"
                    # lottie-web writes a group's paths last first (After Effects
                    # stacks a group's items bottom up); even-odd makes the order moot
                    drawn = _ring_points(ds[0])[::-1]
                    assert len(drawn) == len(rings), f"frame {k} part {p}: ring count"
                    for r, (a, b) in enumerate(zip(drawn, rings, strict=True)):
                        assert a.shape == b.shape, f"frame {k} part {p} ring {r}: point count"
                        err = float(np.abs(a - (b + to_canvas)).max())
                        assert err <= 1e-3 * size, (
                            f"{out.name} frame {k} part {p} ring {r}: {err:.3g} > 1e-3 × {size:.4g}"
                        )
        assert not errors, errors
    finally:
        context.close()
