"""conformorph.pipelines.animation_lottie: the Lottie (Bodymovin JSON) animation of a 2D morph.

The document's structure and numbers are checked here; that lottie-web plays
it as ``frames.json`` says is ``tests/viewer/test_lottie_plays.py``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from conformorph.pipelines.animation_lottie import LottieOptions, lottie_animation


def _frames(n_frames: int = 4) -> list[list[list[np.ndarray]]]:
    """Part 0 a square with a square hole, growing; part 1 a triangle moving right (y up)."""
    sq = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
    tri = np.array([[4.0, 0.0], [5.0, 0.0], [4.5, 1.0]])
    out = []
    for t in np.linspace(0.0, 1.0, n_frames):
        out.append([[(1 + t) * sq, 0.3 * sq[::-1] + [0.2, 0.1]], [tri + [t, 0.0]]])
    return out


def _canvas_ring(doc: dict, layer: int, ring: int, frame: int) -> np.ndarray:
    path = doc["layers"][layer]["shapes"][0]["it"][ring]
    assert path["ty"] == "sh"
    return np.array(path["ks"]["k"][frame]["s"][0]["v"])


def test_document_structure_one_layer_per_part():
    frames = _frames(4)
    doc = json.loads(json.dumps(lottie_animation(frames)))
    assert doc["v"] and doc["fr"] == 30 and doc["ip"] == 0 and doc["op"] == 4
    assert isinstance(doc["w"], int) and isinstance(doc["h"], int)
    assert [layer["ty"] for layer in doc["layers"]] == [4, 4]
    assert [layer["ind"] for layer in doc["layers"]] == [1, 2]
    for layer, rings in zip(doc["layers"], frames[0], strict=True):
        (group,) = layer["shapes"]
        items = group["it"]
        assert [it["ty"] for it in items] == ["sh"] * len(rings) + ["fl", "tr"]
        assert items[-2]["r"] == 2  # even-odd: holes are holes
        assert layer["ip"] == 0 and layer["op"] == 4
        for it, ring in zip(items[: len(rings)], rings, strict=True):
            keys = it["ks"]["k"]
            assert it["ks"]["a"] == 1 and [k["t"] for k in keys] == [0, 1, 2, 3]
            for k in keys:
                shape = k["s"][0]
                assert shape["c"] is True and len(shape["v"]) == len(ring)
                assert shape["i"] == shape["o"] == [[0, 0]] * len(ring)
            # linear between frames: easing handles (0, 0) and (1, 1); the last key ends it
            assert all(k["o"] == {"x": 0, "y": 0} and k["i"] == {"x": 1, "y": 1} for k in keys[:-1])
            assert set(keys[-1]) == {"t", "s"}


def test_canvas_coordinates_are_the_shape_flipped_and_shifted():
    frames = _frames(3)
    doc = lottie_animation(frames, options=LottieOptions(margin=0.1))
    x0, y_top = doc["meta"]["canvas_origin"]
    for k in range(3):
        for layer in range(2):
            for r, ring in enumerate(frames[k][layer]):
                got = _canvas_ring(doc, layer, r, k)
                np.testing.assert_allclose(
                    got, np.c_[ring[:, 0] - x0, y_top - ring[:, 1]], atol=1e-5
                )
    # every frame inside the canvas, with the margin
    pts = np.vstack(
        [_canvas_ring(doc, 0, 0, k) for k in range(3)]
        + [_canvas_ring(doc, 1, 0, k) for k in range(3)]
    )
    assert pts.min() > 0 and np.all(pts.max(axis=0) < [doc["w"], doc["h"]])
    # the canvas is the box of every frame with its margin, to the next whole pixel
    extent = np.ptp(np.vstack([r for p in frames for part in p for r in part]), axis=0)
    assert doc["w"] == np.ceil(extent[0] + 0.2 * extent.max())
    assert doc["h"] == np.ceil(extent[1] + 0.2 * extent.max())


def test_hold_and_single_frame():
    doc = lottie_animation(_frames(3), options=LottieOptions(hold=True, fps=24))
    keys = doc["layers"][0]["shapes"][0]["it"][0]["ks"]["k"]
    assert doc["fr"] == 24 and [k.get("h") for k in keys] == [1, 1, None]
    static = lottie_animation(_frames(1))
    ks = static["layers"][1]["shapes"][0]["it"][0]["ks"]
    assert ks["a"] == 0 and len(ks["k"]["v"]) == 3 and static["op"] == 1


@pytest.mark.parametrize("scale", [1e-4, 1.0, 1e4])
def test_precision_follows_the_size(scale: float):
    frames = [[[r * scale for r in part] for part in parts] for parts in _frames(2)]
    doc = lottie_animation(frames)
    x0, y_top = doc["meta"]["canvas_origin"]
    ring = frames[1][0][0]
    got = _canvas_ring(doc, 0, 0, 1)
    np.testing.assert_allclose(
        got, np.c_[ring[:, 0] - x0, y_top - ring[:, 1]], atol=2e-6 * 7 * scale
    )


def test_errors():
    frames = _frames(3)
    with pytest.raises(ValueError, match="fps"):
        lottie_animation(frames, options=LottieOptions(fps=0))
    bad = [frames[0], [frames[1][0]], frames[2]]
    with pytest.raises(ValueError, match="same parts"):
        lottie_animation(bad)
    with pytest.raises(ValueError, match="at least one frame"):
        lottie_animation([])


@pytest.fixture(scope="module")
def lottie_schema(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The Lottie specification's JSON schema (npm @lottie-animation-community/lottie-specs)."""
    from tests.npm_package import npm_package

    folder = npm_package("@lottie-animation-community/lottie-specs", tmp_path_factory)
    return json.loads((folder / "src" / "data" / "lottie.schema.json").read_text())


def test_valid_against_the_lottie_specification_schema(lottie_schema: dict):
    jsonschema = pytest.importorskip("jsonschema")
    validator = jsonschema.validators.validator_for(lottie_schema)(lottie_schema)
    for doc in (
        lottie_animation(_frames(4)),
        lottie_animation(_frames(3), options=LottieOptions(hold=True)),
        lottie_animation(_frames(1)),
    ):
        doc = json.loads(json.dumps(doc))
        errors = [f"{list(e.absolute_path)}: {e.message[:200]}" for e in validator.iter_errors(doc)]
        assert not errors, errors
    # the schema does check: a fill rule other than 1 or 2 is refused
    bad = json.loads(json.dumps(lottie_animation(_frames(2))))
    bad["layers"][0]["shapes"][0]["it"][-2]["r"] = 7
    assert list(validator.iter_errors(bad))
