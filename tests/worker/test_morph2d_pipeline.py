"""Tests of worker.morph2d_pipeline (end to end on the committed bar fixtures)."""

import json
from pathlib import Path

import numpy as np
import pytest

from geometry.shape_rings import (
    AnchorOutsideShapeError,
    HoleCorrespondenceError,
    SelfIntersectingRingError,
    TooFewAnchorsError,
)
from worker.morph2d_pipeline import run_morph2d

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
BAR_S, BAR_T, BAR_A = (
    SHAPES / "bar_straight.json",
    SHAPES / "bar_bent.json",
    SHAPES / "bar_anchors.json",
)


def test_bar_pair_outputs_and_metrics(tmp_path):
    calls = []
    res = run_morph2d(
        BAR_S,
        BAR_T,
        BAR_A,
        tmp_path,
        frames=11,
        per_frame=True,
        progress=lambda c, t, s: calls.append((c, t, s)),
    )
    assert calls[-1][0] == calls[-1][1]
    assert (tmp_path / "animation.glb").stat().st_size == res["outputs"]["animation_bytes"]
    assert len(list((tmp_path / "frames").glob("*.glb"))) == 11
    assert (tmp_path / "strip.svg").read_text().startswith("<svg")
    on_disk = json.loads((tmp_path / "metrics.json").read_text())
    assert (
        on_disk["methods"]["strain"]["flipped_per_frame"]
        == res["methods"]["strain"]["flipped_per_frame"]
    )
    assert res["mesh"]["route"] == "given" and res["mesh"]["vertices"] == 82
    strain, linear, arap = (res["methods"][k] for k in ("strain", "linear", "arap"))
    assert strain["total_flipped"] == 0 and strain["no_squeezing"] and strain["converged"]
    assert 0.8 < strain["min_area_ratio"] < 0.9 and 1.1 < strain["max_area_ratio"] < 1.2
    assert not linear["no_squeezing"] and linear["min_area_ratio"] < 0.6
    assert arap["total_flipped"] == 0
    assert len(strain["newton_iterations"]) == 11


def test_texture_is_carried(tmp_path):
    import io

    from PIL import Image

    png = tmp_path / "t.png"
    buf = io.BytesIO()
    Image.new("RGB", (4, 4), (255, 0, 0)).save(buf, "PNG")
    png.write_bytes(buf.getvalue())
    res = run_morph2d(BAR_S, BAR_T, BAR_A, tmp_path / "o", frames=3, texture_path=png)
    assert res["outputs"]["animation_bytes"] > 0


def _write(tmp_path: Path, name: str, obj: object) -> Path:
    p = tmp_path / name
    p.write_text(json.dumps(obj))
    return p


def test_named_input_errors(tmp_path):
    sq = [[0, 0], [1, 0], [1, 1], [0, 1]]
    hole = [[0.25, 0.25], [0.25, 0.75], [0.75, 0.75], [0.75, 0.25]]
    s = _write(tmp_path, "s.json", {"rings": [sq]})
    h = _write(tmp_path, "h.json", {"rings": [sq, hole]})
    bow = _write(tmp_path, "b.json", {"rings": [[[0, 0], [1, 1], [1, 0], [0, 1]]]})
    good = _write(tmp_path, "a.json", {"anchors": [[[0, 0], [0, 0]], [[1, 1], [1, 1]]]})
    with pytest.raises(TooFewAnchorsError):
        run_morph2d(
            s, s, _write(tmp_path, "a1.json", {"anchors": [[[0, 0], [0, 0]]]}), tmp_path / "o"
        )
    with pytest.raises(AnchorOutsideShapeError):
        run_morph2d(
            s,
            s,
            _write(tmp_path, "a2.json", {"anchors": [[[0, 0], [0, 0]], [[5, 5], [1, 1]]]}),
            tmp_path / "o",
        )
    with pytest.raises(HoleCorrespondenceError):
        run_morph2d(s, h, good, tmp_path / "o")
    with pytest.raises(SelfIntersectingRingError):
        run_morph2d(bow, s, good, tmp_path / "o")
    with pytest.raises(ValueError):
        run_morph2d(s, s, good, tmp_path / "o", frames=1)
    assert not (tmp_path / "o").exists()


def test_identity_morph_keeps_shape(tmp_path):
    res = run_morph2d(
        BAR_S,
        BAR_S,
        _write(tmp_path, "a.json", {"anchors": [[[0, 0], [0, 0]], [[4, 0], [4, 0]]]}),
        tmp_path / "o",
        frames=4,
    )
    m = res["methods"]["strain"]
    assert m["min_area_ratio"] == pytest.approx(1.0) and m["max_area_ratio"] == pytest.approx(1.0)
    assert np.allclose(res["methods"]["strain"]["translation"], 0.0)


def test_one_hole_pair_end_to_end(tmp_path):
    res = run_morph2d(
        SHAPES / "annulus_round.json",
        SHAPES / "annulus_square.json",
        SHAPES / "anchors_annulus_round__annulus_square.json",
        tmp_path,
        frames=9,
    )
    mesh, strain = res["mesh"], res["methods"]["strain"]
    assert mesh["route"] == "constructed" and mesh["hole_vertices"] > 0
    assert mesh["triangles"] < mesh["overlay_triangles"]
    assert strain["total_flipped"] == 0 and strain["converged"]
    assert res["interp_fallback"] is None
