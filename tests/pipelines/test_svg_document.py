"""SVG features read as the SVG specification's own examples draw them (issue 28)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from conformorph.geometry.shape_rings import ShapeError, ring_signed_area, winding_numbers
from conformorph.pipelines.shape_io import ShapeTooLargeError, parse_shape_parts
from conformorph.pipelines.svg_document import read_svg_shape
from conformorph.pipelines.svg_path import bezier_points, bezier_segment_count

SVG = '<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" viewBox="0 0 1200 400">{}</svg>'


def _parts(body: str, max_points: int = 20_000) -> list[list[np.ndarray]]:
    return read_svg_shape(SVG.format(body), max_points=max_points).parts


def _area(parts: list[list[np.ndarray]]) -> float:
    return sum(
        abs(ring_signed_area(p[0])) - sum(abs(ring_signed_area(h)) for h in p[1:]) for p in parts
    )


@pytest.mark.parametrize("large", [0, 1])
@pytest.mark.parametrize("sweep", [0, 1])
def test_arc_flags_pick_the_four_arcs_of_the_specification(large: int, sweep: int) -> None:
    # SVG 1.1 §8.3.8's figure: an ellipse rx=2 ry=1 (here x 100) through (0,0) and (2,1);
    # the two candidate centres are (0,1) and (2,0); the flags choose centre and side.
    d = f"M0,0 A200,100 0 {large} {sweep} 200,100 Z"
    (part,) = _parts(f'<path d="{d}"/>')
    ring = part[0] * [1, -1]  # back to SVG's y down
    # which side of the chord the painted segment lies on: sweep=1 turns clockwise on
    # screen from (0,0), so its arc bulges to the upper right of the chord (y down)
    c = shapely.Polygon(ring).centroid
    side = np.sign(200 * (c.y - 0) - 100 * (c.x - 0))  # > 0: below-left of the chord
    assert side != 0
    quarter, triangle = math.pi * 200 * 100 / 4, 0.5 * 200 * 100
    expected = 3 * quarter + triangle if large else quarter - triangle
    assert abs(abs(ring_signed_area(ring)) - expected) / expected < 1e-2


def test_nested_transforms_compose() -> None:
    body = (
        '<g transform="translate(100,50)"><g transform="rotate(90)">'
        '<g transform="scale(2,3)"><rect x="0" y="0" width="10" height="10"/></g></g></g>'
    )
    (part,) = _parts(body)
    pts = part[0] * [1, -1]
    # scale (2,3) -> [0,20]x[0,30]; rotate 90 deg: (x, y) -> (-y, x); translate
    assert np.allclose(pts.min(axis=0), [100 - 30, 50], atol=1e-9)
    assert np.allclose(pts.max(axis=0), [100, 50 + 20], atol=1e-9)


def test_rounded_rect_area_and_use_copies() -> None:
    body = '<rect id="r" x="100" y="100" width="400" height="200" rx="50"/><use xlink:href="#r" x="600"/>'
    parts = _parts(body)
    assert len(parts) == 2
    expected = 400 * 200 - (4 - math.pi) * 50**2
    for p in parts:
        # the corners' chords stay within 1e-3 of the drawing's diagonal (1.02 here)
        assert abs(abs(ring_signed_area(p[0])) - expected) / expected < 5e-3


STAR = "M250,75 L323,301 131,161 369,161 177,301 z"  # fill-rule's star (SVG 1.1 §11.3)


def test_evenodd_and_nonzero_on_the_star_and_concentric_rings() -> None:
    nonzero = _parts(f'<path fill-rule="nonzero" d="{STAR}"/>')
    evenodd = _parts(f'<path fill-rule="evenodd" d="{STAR}"/>')
    assert len(nonzero) == 1 and len(nonzero[0]) == 1  # centre painted
    # evenodd: the centre is empty, leaving five points that touch only at corners
    assert len(evenodd) == 5 and all(len(p) == 1 for p in evenodd)
    star = shapely.Polygon(np.array([[250, 75], [323, 301], [131, 161], [369, 161], [177, 301]]))
    whole = _area(nonzero)
    assert abs(_area(evenodd) - (whole - (whole - _area(evenodd)))) < 1e-6
    assert 0.6 < _area(evenodd) / whole < 0.75 and star.area > 0
    # concentric rings drawn the same way (both clockwise) and opposite ways
    same = "M600,200 a100,100 0 1,0 200,0 a100,100 0 1,0 -200,0 z M650,200 a50,50 0 1,0 100,0 a50,50 0 1,0 -100,0 z"
    opposite = "M600,200 a100,100 0 1,0 200,0 a100,100 0 1,0 -200,0 z M650,200 a50,50 0 1,1 100,0 a50,50 0 1,1 -100,0 z"
    full, ring = math.pi * 100**2, math.pi * (100**2 - 50**2)
    for d, rule, want in [
        (same, "nonzero", full),
        (same, "evenodd", ring),
        (opposite, "nonzero", ring),
        (opposite, "evenodd", ring),
    ]:
        got = _area(_parts(f'<path fill-rule="{rule}" d="{d}"/>'))
        assert abs(got - want) / want < 1e-2, (rule, got, want)  # chords of 1e-3 x 1265


@pytest.mark.parametrize(
    ("cap", "extra"), [("butt", 0.0), ("square", 2 * 10 * 20), ("round", math.pi * 10**2)]
)
def test_stroke_outline_area_is_length_times_width_plus_caps(cap: str, extra: float) -> None:
    body = f'<line x1="100" y1="100" x2="500" y2="100" stroke="#000" stroke-width="20" stroke-linecap="{cap}"/>'
    shape = read_svg_shape(SVG.format(body), max_points=20_000)
    assert shape.stroked == 1 and "outlined" in shape.notes[0]
    want = 400 * 20 + extra  # length x width + two caps (a square cap adds r x width each)
    assert abs(_area(shape.parts) - want) / want < 3e-3


def test_outline_icon_strokes_make_holes_and_fill_unions_stroke() -> None:
    # a stroked circle with fill="none" paints a ring: one part with one hole
    (part,) = _parts(
        '<circle cx="200" cy="200" r="100" fill="none" stroke="black" stroke-width="20"/>'
    )
    assert len(part) == 2
    assert abs(_area([part]) - math.pi * (110**2 - 90**2)) / (math.pi * 4000) < 2e-2
    # filled and stroked: the union, a disk of radius r + width / 2
    (disk,) = _parts('<circle cx="200" cy="200" r="100" stroke="black" stroke-width="20"/>')
    assert len(disk) == 1 and abs(_area([disk]) - math.pi * 110**2) / (math.pi * 110**2) < 1e-2


def test_css_style_and_hidden_elements() -> None:
    body = (
        "<style>.k { fill: none; stroke: black; stroke-width: 10 }</style>"
        '<rect class="k" x="0" y="0" width="100" height="100"/>'
        '<rect x="300" y="0" width="100" height="100" style="display:none"/>'
        '<defs><rect x="600" y="0" width="100" height="100"/></defs>'
    )
    (part,) = _parts(body)
    assert len(part) == 2  # an outlined square: the stroke's ring
    assert abs(_area([part]) - (110**2 - 90**2)) < 1e-6


def test_hostile_documents_are_refused() -> None:
    with pytest.raises(ShapeError, match="entities"):
        read_svg_shape('<!DOCTYPE s [<!ENTITY x "y">]><svg/>', max_points=100)
    nested = (
        '<g id="a"><rect width="1" height="1"/></g><g id="b"><use href="#a"/></g><use href="#b"/>'
    )
    with pytest.raises(ShapeError, match="nested <use>"):
        read_svg_shape(SVG.format(nested), max_points=100)
    with pytest.raises(ShapeTooLargeError, match="as written"):
        read_svg_shape(
            SVG.format('<polygon points="' + "0,0 1,0 1,1 " * 50 + '"/>'), max_points=100
        )
    with pytest.raises(ShapeError, match="paints nothing"):
        read_svg_shape(SVG.format('<rect width="1" height="1" fill="none"/>'), max_points=100)


def test_bezier_flattening_meets_its_tolerance() -> None:
    ctrl = np.array([[0.0, 0], [1, 3], [3, -2], [4, 1]])
    for tol in (1e-1, 1e-2, 1e-3):
        n = bezier_segment_count(ctrl, tol)
        poly = np.vstack([ctrl[:1], bezier_points(ctrl, n)])
        dense = np.vstack([ctrl[:1], bezier_points(ctrl, 4000)])
        dist = shapely.LineString(poly).hausdorff_distance(shapely.LineString(dense))
        assert dist <= tol * 1.01
        assert n == 1 or bezier_segment_count(ctrl, tol * 4) < n  # adaptive, not fixed


def test_winding_numbers_by_hand() -> None:
    sq = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2]])
    assert winding_numbers([sq, sq[::-1] * 0.5 + 0.5], [[1, 1], [0.1, 0.1]]).tolist() == [0, 1]


def test_json_parts_document() -> None:
    doc = parse_shape_parts(
        '{"parts": [{"rings": [[[0,0],[1,0],[0,1]]]}, {"rings": [[[5,5],[6,5],[5,6]]]}]}',
        ".json",
        "p.json",
    )
    assert len(doc.parts) == 2


def test_a_hole_touching_its_outline_is_pulled_apart() -> None:
    from conformorph.geometry.shape_rings import validate_rings

    d = "M0,0 H100 V100 H0 Z M50,0 L70,40 L30,40 Z"  # the hole's tip on the outline
    shape = read_svg_shape(SVG.format(f'<path fill-rule="evenodd" d="{d}"/>'), max_points=1000)
    assert any("touched" in n for n in shape.notes)
    for rings in shape.parts:
        validate_rings(rings)  # raised "rings 0 and 1 intersect" before the repair
    assert abs(_area(shape.parts) - (100 * 100 - 0.5 * 40 * 40)) / 9200 < 1e-2


def test_parts_touching_at_a_corner_are_parted() -> None:
    import shapely

    # two squares drawn corner to corner: a valid MultiPolygon whose parts meet at a point
    svg = SVG.format(
        '<rect x="0" y="0" width="50" height="50"/><rect x="50" y="50" width="50" height="50"/>'
    )
    shape = read_svg_shape(svg, max_points=1000)
    assert len(shape.parts) == 2 and any("touched another part" in n for n in shape.notes)
    a, b = (shapely.Polygon(rings[0], rings[1:]) for rings in shape.parts)
    assert not a.intersects(b) and 0 < a.distance(b) < 1.0
    assert abs(_area(shape.parts) - 2 * 50 * 50) / 5000 < 1e-2
    # apart: nothing eroded
    svg = SVG.format(
        '<rect x="0" y="0" width="50" height="50"/><rect x="60" y="60" width="40" height="40"/>'
    )
    assert not read_svg_shape(svg, max_points=1000).notes


def test_use_of_itself_is_refused() -> None:
    with pytest.raises(ShapeError, match="nested <use>"):
        read_svg_shape(
            SVG.format('<use id="u" href="#u"/><rect width="1" height="1"/>'), max_points=100
        )


def test_an_editor_export_with_doctype_css_class_and_units() -> None:
    # the header an editor writes: XML declaration, comment, external DTD (not fetched),
    # width/height in px with a viewBox, a <style> sheet and a class
    text = (
        '<?xml version="1.0" encoding="utf-8"?>\n<!-- Generator: an editor -->\n'
        '<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" '
        '"http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd">\n'
        '<svg version="1.1" xmlns="http://www.w3.org/2000/svg" x="0px" y="0px" width="200px" '
        'height="100px" viewBox="0 0 100 50" xml:space="preserve">'
        '<style type="text/css">.st0{fill:#FF0000;}</style>'
        '<g><polygon class="st0" points="10,10 90,10 50,45"/></g></svg>'
    )
    (part,) = read_svg_shape(text, max_points=100).parts
    # coordinates of the file's user units (the viewBox's), y up: not the 2x viewport
    assert sorted(map(tuple, part[0].tolist())) == [(10.0, -10.0), (50.0, -45.0), (90.0, -10.0)]
