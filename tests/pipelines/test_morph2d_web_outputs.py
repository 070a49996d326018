"""Tests of the web outputs of the 2D morph: ``animation.svg`` and ``frames.json``."""

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from conformorph.pipelines.morph2d import (
    frame_parts,
    frame_rings,
    run_morph2d,
    write_web_outputs,
)

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
SVG = "{http://www.w3.org/2000/svg}"


def _annulus(k: int) -> tuple[np.ndarray, np.ndarray]:
    """A square annulus (8 vertices, 8 triangles) scaled by 1 + k."""
    outer = [[0, 0], [3, 0], [3, 3], [0, 3]]
    inner = [[1, 1], [2, 1], [2, 2], [1, 2]]
    V = np.array(outer + inner, float) * (1 + k)
    F = []
    for i in range(4):
        j = (i + 1) % 4
        F += [[i, j, 4 + j], [i, 4 + j, 4 + i]]
    return V, np.array(F, np.int64)


def test_frame_rings_are_the_outline_then_the_holes():
    frames = np.stack([_annulus(k)[0] for k in range(3)])
    F = _annulus(0)[1]
    rings = frame_rings(frames, F)
    assert len(rings) == 3 and [len(r) for r in rings[0]] == [4, 4]
    np.testing.assert_allclose(sorted(map(tuple, rings[2][0])), sorted(map(tuple, frames[2][:4])))
    np.testing.assert_allclose(sorted(map(tuple, rings[1][1])), sorted(map(tuple, frames[1][4:])))


def test_frame_parts_are_the_mesh_components():
    V, F = _annulus(0)
    tri = np.array([[10.0, 0.0], [11.0, 0.0], [10.0, 1.0]])
    # the triangle first in the vertex order: it is part 0
    V2 = np.vstack([tri, V])
    F2 = np.vstack([[[0, 1, 2]], F + 3])
    frames = np.stack([V2, V2 * 2.0])
    parts = frame_parts(frames, F2)
    assert len(parts) == 2 and [[len(r) for r in p] for p in parts[0]] == [[3], [4, 4]]
    np.testing.assert_allclose(sorted(map(tuple, parts[1][0][0])), sorted(map(tuple, tri * 2)))
    # one component: the one part is frame_rings
    (one,) = frame_parts(frames[:, 3:], F)[1]
    for a, b in zip(one, frame_rings(frames[:, 3:], F)[1], strict=True):
        np.testing.assert_array_equal(a, b)


def test_loop_reaches_animation_svg(tmp_path):
    frames = np.stack([_annulus(k)[0] for k in range(3)])
    write_web_outputs(tmp_path, frames, _annulus(0)[1], np.linspace(0, 1, 3), loop="alternate")
    animate = ET.parse(tmp_path / "animation.svg").getroot().find(f"{SVG}path/{SVG}animate")
    assert animate is not None and len(animate.get("values", "").split(";")) == 5


def test_web_outputs_parse_and_have_one_value_per_frame(tmp_path):
    frames = np.stack([_annulus(k)[0] for k in range(5)])
    F = _annulus(0)[1]
    times = np.array([0.0, 0.1, 0.3, 0.7, 1.0])
    names = write_web_outputs(tmp_path, frames, F, times)
    assert names == {
        "animation_svg": "animation.svg",
        "lottie": "animation.json",
        "frames_json": "frames.json",
    }
    lottie = json.loads((tmp_path / "animation.json").read_text())
    assert lottie["op"] == 5 and len(lottie["layers"]) == 1
    root = ET.parse(tmp_path / "animation.svg").getroot()
    animate = root.find(f"{SVG}path/{SVG}animate")
    assert animate is not None
    assert len(animate.get("values", "").split(";")) == 5
    assert len(animate.get("keyTimes", "").split(";")) == 5
    doc = json.loads((tmp_path / "frames.json").read_text())
    assert doc["frame_times"] == times.tolist() and len(doc["frames"]) == 5
    assert len(doc["frames"][0]["holes"]) == 1 and len(doc["faces"]) == len(F)
    np.testing.assert_allclose(doc["frames"][4]["vertices"], frames[4] * [1, -1])


def test_every_morph_writes_the_web_outputs(tmp_path):
    bar = [SHAPES / "bar_straight.json", SHAPES / "bar_bent.json", SHAPES / "bar_anchors.json"]
    from conformorph.pipelines.morph2d import Morph2DOptions

    m = run_morph2d(*bar, tmp_path, Morph2DOptions(frames=7))
    assert m["outputs"]["animation_svg"] == "animation.svg"
    assert m["outputs"]["frames_json"] == "frames.json"
    assert m["outputs"]["lottie"] == "animation.json" and m["loop"] == "once"
    root = ET.parse(tmp_path / "animation.svg").getroot()
    animate = root.find(f"{SVG}path/{SVG}animate")
    assert animate is not None and len(animate.get("values", "").split(";")) == 7
    doc = json.loads((tmp_path / "frames.json").read_text())
    assert len(doc["frames"]) == 7 and doc["frame_times"] == m["frame_t"]
