"""Tests of worker.shape_io."""

import json
from pathlib import Path

import numpy as np
import pytest

from geometry.shape_rings import ShapeError, TooFewAnchorsError
from worker.shape_io import parse_svg_path, read_anchors, read_shape

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"


def test_svg_path_hand_worked_absolute_relative_and_y_flip(tmp_path):
    rings = parse_svg_path("M0,0 L2,0 l0,2 H0 Z m0.5,0.5 h1 v1 h-1 z")
    assert np.array_equal(rings[0], [[0, 0], [2, 0], [2, 2], [0, 2]])
    assert np.array_equal(rings[1], [[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5]])
    p = tmp_path / "s.svg"
    p.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg"><path d="M0,0 L2,0 L2,2 L0,2 Z M0.5,0.5 h1 v1 h-1 z"/></svg>'
    )
    r = read_shape(p)
    assert np.array_equal(r[0][:, 1], [0, 0, -2, -2])  # y negated, outer (largest) first
    assert len(r) == 2


def test_curves_are_flattened_and_arcs_refused():
    (ring,) = parse_svg_path("M0,0 Q1,2 2,0 Z")
    assert ring.shape == (9, 2)  # start + 8 segments
    assert np.allclose(ring[4], [1.0, 1.0])  # quadratic Bézier midpoint
    with pytest.raises(ShapeError, match="arcs"):
        parse_svg_path("M0,0 A1,1 0 0 1 2,0 Z")


def test_json_rings_match_the_svg_preview():
    j = read_shape(SHAPES / "bar_straight.json")
    assert j[0].shape == (82, 2)


def test_anchor_errors(tmp_path):
    p = tmp_path / "a.json"
    p.write_text(json.dumps({"anchors": [[[0, 0], [1, 1]]]}))
    with pytest.raises(TooFewAnchorsError, match="at least 2"):
        read_anchors(p)
    p.write_text(json.dumps({"anchors": [[0, 0], [1, 1]]}))
    with pytest.raises(ShapeError):
        read_anchors(p)
    p.write_text("{")
    with pytest.raises(ShapeError, match="JSON"):
        read_anchors(p)
    a = read_anchors(SHAPES / "bar_anchors.json")
    assert a.shape == (2, 2, 2)


def test_bad_shape_json(tmp_path):
    p = tmp_path / "s.json"
    p.write_text(json.dumps({"ring": []}))
    with pytest.raises(ShapeError, match="rings"):
        read_shape(p)
