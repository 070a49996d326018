"""conformorph.pipelines.animation_svg: SMIL animation.svg and frames.json of a 2D morph."""

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conformorph.pipelines.animation_svg import (
    AnimationSvgOptions,
    animation_svg,
    frames_json,
    ring_path_d,
)
from conformorph.pipelines.shape_io import parse_svg_path

SVG = "{http://www.w3.org/2000/svg}"


def _frames(n_frames: int = 5) -> tuple[list[list[np.ndarray]], np.ndarray]:
    """A square with a square hole, growing and turning; times 0 ... 1."""
    sq = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
    times = np.linspace(0.0, 1.0, n_frames)
    frames = []
    for t in times:
        c, s = np.cos(t), np.sin(t)
        R = np.array([[c, -s], [s, c]])
        frames.append([(1 + t) * sq @ R.T, 0.3 * sq[::-1] @ R.T + [0.2, 0.1]])
    return frames, times


def _parts(frames: list[list[np.ndarray]]) -> list[list[list[np.ndarray]]]:
    """Frames of one part each (the layout before shapes had several parts)."""
    return [[rings] for rings in frames]


def test_path_d_by_hand():
    assert (
        ring_path_d([[0, 0], [1.5, 0], [0, 2]], digits=2) == "M0.00,0.00 L1.50,0.00 L0.00,-2.00 Z"
    )


def test_svg_parses_and_animates_every_frame():
    frames, times = _frames(7)
    text = animation_svg(_parts(frames), times, options=AnimationSvgOptions(duration_s=2.5))
    root = ET.fromstring(text)
    assert root.tag == SVG + "svg"
    (path,) = root.iter(SVG + "path")
    assert path.get("fill-rule") == "evenodd"
    (anim,) = path.iter(SVG + "animate")
    assert anim.get("attributeName") == "d"
    # by default it plays once and holds the last frame
    assert anim.get("calcMode") == "linear" and anim.get("repeatCount") == "1"
    assert anim.get("fill") == "freeze"
    assert anim.get("dur") == "2.5s"
    values = anim.get("values").split(";")
    keys = [float(k) for k in anim.get("keyTimes").split(";")]
    assert len(values) == len(keys) == len(frames)
    np.testing.assert_allclose(keys, times, atol=1e-6)
    assert path.get("d") == values[0]
    # same commands in the same order in every frame (SMIL interpolates only those)
    letters = {"".join(ch for ch in v if ch.isalpha()) for v in values}
    assert letters == {"MLLLZMLLLZ"}
    # the d strings round-trip: SVG coordinates are (x, -y)
    for v, rings in zip(values, frames, strict=True):
        back = parse_svg_path(v)
        assert len(back) == 2
        for b, r in zip(back, rings, strict=True):
            np.testing.assert_allclose(b * [1, -1], r, atol=1e-3)
    # every frame inside the viewBox
    x0, y0, w, h = (float(x) for x in root.get("viewBox").split())
    pts = np.vstack([r for rings in frames for r in rings]) * [1, -1]
    assert np.all(pts >= [x0, y0]) and np.all(pts <= [x0 + w, y0 + h])


def test_uneven_times_become_key_times():
    frames, _ = _frames(3)
    root = ET.fromstring(animation_svg(_parts(frames), [2.0, 2.5, 4.0]))
    anim = next(root.iter(SVG + "animate"))
    np.testing.assert_allclose([float(k) for k in anim.get("keyTimes").split(";")], [0, 0.25, 1])


def test_single_frame_is_static():
    frames, times = _frames(1)
    root = ET.fromstring(animation_svg(_parts(frames), times))
    assert not list(root.iter(SVG + "animate"))


def test_frames_json_structure_and_round_trip():
    frames, times = _frames(4)
    V = np.stack([np.vstack(rings) for rings in frames])  # (4, 8, 2)
    F = np.array([[0, 1, 4], [1, 2, 5]])
    doc = json.loads(json.dumps(frames_json(_parts(frames), times, V, F)))
    assert doc["frame_times"] == pytest.approx(times.tolist())
    assert doc["faces"] == F.tolist()
    assert len(doc["frames"]) == 4
    for k, fr in enumerate(doc["frames"]):
        assert fr["t"] == pytest.approx(times[k])
        (outer,) = parse_svg_path(fr["outline"])
        np.testing.assert_allclose(outer * [1, -1], frames[k][0], atol=1e-6)
        assert len(fr["holes"]) == 1
        np.testing.assert_allclose(
            parse_svg_path(fr["holes"][0])[0] * [1, -1], frames[k][1], atol=1e-6
        )
        np.testing.assert_allclose(np.array(fr["vertices"]) * [1, -1], V[k], atol=1e-6)


def test_errors():
    frames, times = _frames(3)
    with pytest.raises(ValueError, match="frame_times"):
        animation_svg(_parts(frames), times[:2])
    with pytest.raises(ValueError, match="non-decreasing"):
        animation_svg(_parts(frames), times[::-1])
    bad = [frames[0], [frames[1][0][:3], frames[1][1]], frames[2]]
    with pytest.raises(ValueError, match="same rings"):
        animation_svg(_parts(bad), times)
    V = np.zeros((3, 8, 2))
    with pytest.raises(ValueError, match="vertices"):
        frames_json(_parts(frames), times, V[:2], [[0, 1, 2]])
    with pytest.raises(ValueError, match="faces"):
        frames_json(_parts(frames), times, V, [[0, 1, 8]])


def _two_parts(n_frames: int = 4) -> tuple[list[list[list[np.ndarray]]], np.ndarray]:
    """Part 0: the square with a hole of :func:`_frames`; part 1: a triangle moving right."""
    frames, times = _frames(n_frames)
    tri = np.array([[4.0, 0.0], [5.0, 0.0], [4.5, 1.0]])
    return [[rings, [tri + [t, 0.0]]] for rings, t in zip(frames, times, strict=True)], times


def test_one_path_per_part_with_its_own_frames():
    parts, times = _two_parts(4)
    root = ET.fromstring(animation_svg(parts, times))
    paths = list(root.iter(SVG + "path"))
    assert len(paths) == 2
    for p, path in enumerate(paths):
        values = next(path.iter(SVG + "animate")).get("values").split(";")
        assert len(values) == 4
        for k, v in enumerate(values):
            back = parse_svg_path(v)
            assert len(back) == len(parts[k][p])
            for b, r in zip(back, parts[k][p], strict=True):
                np.testing.assert_allclose(b * [1, -1], r, atol=1e-3)
    doc = frames_json(parts, times, np.zeros((4, 3, 2)), [[0, 1, 2]])
    fr = doc["frames"][3]
    assert len(fr["parts"]) == 2 and len(fr["parts"][0]["holes"]) == 1
    assert fr["parts"][1]["holes"] == []
    # the layout before parts: outline and holes of the first part
    assert fr["outline"] == fr["parts"][0]["outline"] and fr["holes"] == fr["parts"][0]["holes"]
    np.testing.assert_allclose(
        parse_svg_path(fr["parts"][1]["outline"])[0] * [1, -1], parts[3][1][0], atol=1e-6
    )


@pytest.mark.parametrize("loop", ["once", "repeat", "alternate"])
def test_loop_modes(loop: str):
    frames, _ = _frames(5)
    times = np.array([0.0, 0.1, 0.3, 0.7, 1.0])
    opts = AnimationSvgOptions(duration_s=2.0, loop=loop)
    anim = next(
        ET.fromstring(animation_svg(_parts(frames), times, options=opts)).iter(SVG + "animate")
    )
    values = anim.get("values").split(";")
    keys = np.array([float(k) for k in anim.get("keyTimes").split(";")])
    assert anim.get("fill") == "freeze" and keys[0] == 0.0 and keys[-1] == 1.0
    if loop == "alternate":
        # there and back over twice the duration: the values and key times mirrored
        assert anim.get("dur") == "4s" and anim.get("repeatCount") == "indefinite"
        assert len(values) == 9 and values == values[::-1]
        np.testing.assert_allclose(keys[:5], times / 2, atol=1e-6)
        np.testing.assert_allclose(keys, 1.0 - keys[::-1], atol=2e-6)
    else:
        assert anim.get("dur") == "2s" and len(values) == 5
        assert anim.get("repeatCount") == ("1" if loop == "once" else "indefinite")
        np.testing.assert_allclose(keys, times, atol=1e-6)


def test_unknown_loop_is_refused():
    frames, times = _frames(3)
    with pytest.raises(ValueError, match="loop must be one of once, repeat, alternate"):
        animation_svg(_parts(frames), times, options=AnimationSvgOptions(loop="bounce"))
