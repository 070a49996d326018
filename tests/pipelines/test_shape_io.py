"""Tests of conformorph.pipelines.shape_io."""

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.geometry.shape_rings import (
    PathError,
    ShapeError,
    TooFewAnchorsError,
    ring_signed_area,
)
from conformorph.pipelines.shape_io import (
    MAX_ANCHORS,
    MAX_JSON_DEPTH,
    ShapeTooLargeError,
    SvgPathError,
    json_depth,
    parse_svg_path,
    read_anchor_paths,
    read_anchors,
    read_shape,
)

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"


def test_svg_path_hand_worked_absolute_relative_and_y_flip(tmp_path):
    rings = parse_svg_path("M0,0 L2,0 l0,2 H0 Z m0.5,0.5 h1 v1 h-1 z")
    assert np.array_equal(rings[0], [[0, 0], [2, 0], [2, 2], [0, 2]])
    assert np.array_equal(rings[1], [[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5]])
    p = tmp_path / "s.svg"
    d = "M0,0 L2,0 L2,2 L0,2 Z M0.5,0.5 h1 v1 h-1 z"
    p.write_text(f'<svg xmlns="http://www.w3.org/2000/svg"><path d="{d}" fill-rule="evenodd"/></svg>')
    r = read_shape(p)
    assert len(r) == 2  # outer (largest) first, then the hole
    assert sorted(set(r[0][:, 1].tolist())) == [-2, 0]  # y negated
    assert abs(sum(abs(ring_signed_area(x)) * (1 if k == 0 else -1) for k, x in enumerate(r)) - 3) < 1e-12
    # nonzero (the default) with both rings turning the same way: no hole (SVG 2 §13.4.2)
    p.write_text(f'<svg xmlns="http://www.w3.org/2000/svg"><path d="{d}"/></svg>')
    (outer,) = read_shape(p)
    assert abs(abs(ring_signed_area(outer)) - 4) < 1e-12


def test_curves_are_flattened_adaptively_and_arcs_read():
    (ring,) = parse_svg_path("M0,0 Q1,2 2,0 Z", tol=0.01)
    # Wang's bound for a quadratic: n >= sqrt(2/8 * |P0 - 2 P1 + P2| / tol) = sqrt(100) = 10
    assert ring.shape == (11, 2)  # start + 10 segments
    assert np.allclose(ring[5], [1.0, 1.0])  # quadratic Bézier midpoint
    (coarse,) = parse_svg_path("M0,0 Q1,2 2,0 Z", tol=0.1)
    assert coarse.shape[0] < ring.shape[0]
    (half,) = parse_svg_path("M0,0 A1,1 0 0 1 2,0 Z", tol=1e-3)
    assert np.allclose(np.linalg.norm(half - [1, 0], axis=1), 1.0)  # on the circle


def test_json_rings_match_the_svg_preview():
    # bar_straight.svg is the shape collection's preview of bar_straight.json
    # (y down, coordinates printed with 3 decimals), drawn with a 0.016 outline stroke:
    # the SVG reads as what it paints, the bar grown by half the stroke width.
    j = read_shape(SHAPES / "bar_straight.json")
    v = read_shape(SHAPES / "bar_straight.svg")
    assert len(j) == len(v) == 1
    assert j[0].shape == (82, 2)
    lo_j, hi_j = j[0].min(axis=0), j[0].max(axis=0)
    assert np.abs(v[0].min(axis=0) - (lo_j - 0.008)).max() < 5e-4
    assert np.abs(v[0].max(axis=0) - (hi_j + 0.008)).max() < 5e-4


@pytest.mark.timeout(10)
def test_numbers_after_close_path_are_an_error_not_a_hang():
    with pytest.raises(SvgPathError, match="'5' at position 17 follows 'Z'"):
        parse_svg_path("M0,0 L1,0 L0,1 Z 5 5")
    with pytest.raises(SvgPathError, match="position 12 follows .z."):
        parse_svg_path("M0,0 L1,0 z 2,2 L3,3")


def test_unknown_commands_and_characters_are_named_with_their_position():
    with pytest.raises(SvgPathError, match="unknown command 'X' at position 0"):
        parse_svg_path("X5,5")
    with pytest.raises(SvgPathError, match="unknown command 'X' at position 10"):
        parse_svg_path("M0,0 L1,0 X0,1 Z")
    with pytest.raises(SvgPathError, match="unexpected character '#' at position 15"):
        parse_svg_path("M0,0 L1,0 L0,1 # Z")
    with pytest.raises(SvgPathError, match="must start with a command, got '5' at position 0"):
        parse_svg_path("5 5 M0,0 L1,0 L0,1 Z")
    with pytest.raises(SvgPathError, match=r"'L' needs 2 numbers \(position 7\)"):
        parse_svg_path("M0,0 L1")
    assert issubclass(SvgPathError, ValueError)
    # separators: commas, any whitespace, numbers run together by signs and dots
    (ring,) = parse_svg_path("M0 0\tL2-0\nL.5.5z")
    assert np.array_equal(ring, [[0, 0], [2, 0], [0.5, 0.5]])


def test_json_depth_hand_worked():
    assert json_depth("1") == 0
    assert json_depth("[1, 2]") == 1
    assert json_depth('{"a": [[1]]}') == 3
    assert json_depth('{"a": "[[[[ ]] \\" {"}') == 1  # brackets inside strings do not count
    assert json_depth("[[[]], [[[[]]]]]") == 5


@pytest.mark.parametrize("reader", [read_shape, read_anchors])
def test_deeply_nested_json_is_refused_with_a_message(tmp_path, reader):
    key = "rings" if reader is read_shape else "anchors"
    p = tmp_path / "deep.json"
    p.write_text(f'{{"{key}": {"[" * 100_000}{"]" * 100_000}}}')
    with pytest.raises(
        ShapeTooLargeError, match=f"nested 100001 levels deep; at most {MAX_JSON_DEPTH}"
    ):
        reader(p)


def test_size_and_point_limits(tmp_path):
    bar = SHAPES / "bar_straight.json"
    with pytest.raises(ShapeTooLargeError, match="82 points; the limit is 81"):
        read_shape(bar, max_points=81)
    assert read_shape(bar, max_points=82)[0].shape == (82, 2)
    with pytest.raises(ShapeTooLargeError, match="82 points as written, more than 81"):
        read_shape(SHAPES / "bar_straight.svg", max_points=81)
    with pytest.raises(ShapeTooLargeError, match="bytes; the limit is 100"):
        read_shape(bar, max_bytes=100)
    # points count as written (a curve counts one), not after flattening
    assert parse_svg_path("M0,0 Q1,2 2,0 Z", max_points=2)[0].shape[0] > 2
    with pytest.raises(ShapeTooLargeError):
        parse_svg_path("M0,0 Q1,2 2,0 Z", max_points=1)
    p = tmp_path / "many.json"
    p.write_text(json.dumps({"anchors": [[[0, 0], [0, 0]]] * (MAX_ANCHORS + 1)}))
    with pytest.raises(ShapeTooLargeError, match=f"{MAX_ANCHORS + 1} anchor pairs"):
        read_anchors(p)
    p.write_bytes(b'{"rings": [[[0, 0], [1, 0], [0, 1]]], "name": "\xff"}')
    with pytest.raises(ShapeError, match="not UTF-8"):
        read_shape(p)


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


def test_anchor_paths_are_optional_lists_of_anchor_indices(tmp_path):
    p = tmp_path / "a.json"
    anchors = [[[0, 0], [0, 0]], [[1, 0], [2, 0]], [[1, 1], [2, 1]]]
    p.write_text(json.dumps({"anchors": anchors}))
    assert read_anchor_paths(p) == []
    p.write_text(json.dumps({"anchors": anchors, "paths": [[0, 2], [1, 0, 2]]}))
    assert read_anchor_paths(p) == [[0, 2], [1, 0, 2]]
    for paths, index, message in [
        ({"0": 1}, 0, "must be a list"),
        ([[0, 2], [1]], 1, r"paths\[1\] must be \[i, …, j\]"),
        ([[0, 2.5]], 0, "at least two anchor indices"),
        ([[0, True]], 0, "at least two anchor indices"),
        ([[0, 3]], 0, "names anchor 3; there are 3 anchors"),
        ([[0, -1]], 0, "names anchor -1"),
    ]:
        p.write_text(json.dumps({"anchors": anchors, "paths": paths}))
        with pytest.raises(PathError, match=message) as info:
            read_anchor_paths(p)
        assert info.value.index == index
        assert "a.json" in str(info.value)
