"""Shapes of several parts: matching, growing/shrinking, no part crossing another (issue 28)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from conformorph.pipelines.morph2d.run import run_morph2d

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
TWO = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><circle cx="7" cy="12" r="4"/><rect x="13" y="8" width="8" height="8" rx="2"/></svg>'
ONE = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><ellipse cx="12" cy="12" rx="9" ry="5"/></svg>'
RING = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><path fill-rule="evenodd" d="M12 2a10 10 0 1 0 0 20a10 10 0 1 0 0-20zM12 7a5 5 0 1 1 0 10a5 5 0 1 1 0-10z"/></svg>'
SQUARE = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><rect x="3" y="3" width="18" height="18" rx="3"/></svg>'


@pytest.mark.timeout(120)
def test_two_parts_to_one_without_crossing(tmp_path: Path) -> None:
    assert (SHAPES / "parts_two.svg").read_text().strip() == TWO  # the committed pair
    assert (SHAPES / "parts_one.svg").read_text().strip() == ONE
    (tmp_path / "a.svg").write_text(TWO)
    (tmp_path / "b.svg").write_text(ONE)
    m = run_morph2d(tmp_path / "a.svg", tmp_path / "b.svg", None, tmp_path / "o")
    parts = m["parts"]
    assert parts["source_parts"] == 2 and parts["target_parts"] == 1
    assert parts["matching"]["pairs"] == [[0, 0]] and parts["matching"]["unmatched_source"] == [1]
    assert m["reached_target"] and m["methods"]["strain"]["total_flipped"] == 0
    assert parts["overlapping_frames"] == 0 and parts["self_crossing_frames"] == 0
    # shrinking together with the growth overlaps: the re-timed schedule was needed
    assert parts["schedules_tried"]["together"]["overlapping_frames"] > 0
    doc = json.loads((tmp_path / "o" / "frames.json").read_text())
    assert all(len(f["parts"]) == 2 for f in doc["frames"])  # the speck stays a part


@pytest.mark.timeout(120)
def test_one_hole_to_none_and_strokes_recorded(tmp_path: Path) -> None:
    assert (SHAPES / "ring_one_hole.svg").read_text().strip() == RING
    assert (SHAPES / "rounded_square.svg").read_text().strip() == SQUARE
    (tmp_path / "a.svg").write_text(RING)
    (tmp_path / "b.svg").write_text(SQUARE)
    m = run_morph2d(tmp_path / "a.svg", tmp_path / "b.svg", None, tmp_path / "o")
    assert m["reached_target"] and m["methods"]["strain"]["total_flipped"] == 0
    assert m["mesh"]["seeded_holes"]  # the hole shrinks into a seed in the square
    assert m["crossings"]["self_crossing_frames"] == 0  # the hole never crosses the outline
    assert m["svg"]["source"] == ["fill rules applied: evenodd"]
    assert m["strokes_outlined"] == {"source": 0, "target": 0}


SWAP_A = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 40 20"><rect x="1" y="1" width="16" height="16"/><rect x="30" y="7" width="4" height="4"/></svg>'
SWAP_B = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 40 20"><rect x="5" y="7" width="4" height="4"/><rect x="22" y="1" width="16" height="16"/></svg>'


@pytest.mark.timeout(180)
def test_pairs_that_would_cross_are_separated(tmp_path: Path) -> None:
    # big left -> big right and small right -> small left pass through each other
    (tmp_path / "a.svg").write_text(SWAP_A)
    (tmp_path / "b.svg").write_text(SWAP_B)
    m = run_morph2d(tmp_path / "a.svg", tmp_path / "b.svg", None, tmp_path / "o")
    parts = m["parts"]
    assert parts["matching"]["pairs"] == [
        [0, 0],
        [1, 1],
    ]  # big to big (parts by area): they swap sides
    assert parts["overlapping_frames"] == 0 and parts["self_crossing_frames"] == 0
    assert any(p["separated"] for p in parts["pairs"])
    assert m["methods"]["strain"]["total_flipped"] == 0 and m["reached_target"]


@pytest.mark.timeout(120)
def test_anchors_pin_a_part_pair_and_name_it(tmp_path: Path) -> None:
    (tmp_path / "a.svg").write_text(TWO)
    (tmp_path / "b.svg").write_text(ONE)
    # parts by area: the rounded square (60.6) is 0, the disk (50.3) is 1; unpinned, the
    # square takes the ellipse (test_two_parts_to_one_without_crossing); the anchor pins the disk
    disk_left, ellipse_left = [3.0, -12.0], [3.0, -12.0]  # boundary points seed the outline match
    anchors = {"anchors": [[disk_left, ellipse_left]], "parts": [[1, 0]]}
    (tmp_path / "anchors.json").write_text(json.dumps(anchors))
    m = run_morph2d(
        tmp_path / "a.svg", tmp_path / "b.svg", tmp_path / "anchors.json", tmp_path / "o"
    )
    assert m["parts"]["matching"]["pinned"] == [[1, 0]]
    assert m["parts"]["matching"]["pairs"] == [[1, 0]]
    assert m["parts"]["overlapping_frames"] == 0
    written = json.loads((tmp_path / "o" / "anchors.json").read_text())
    assert written["parts"][0] == [1, 0] and written["anchors"][0] == anchors["anchors"][0]
    anchors["parts"] = [[0, 0]]  # the square does not hold that point
    (tmp_path / "anchors.json").write_text(json.dumps(anchors))
    with pytest.raises(ValueError, match="does not lie in part 0") as info:
        run_morph2d(
            tmp_path / "a.svg", tmp_path / "b.svg", tmp_path / "anchors.json", tmp_path / "p"
        )
    assert getattr(info.value, "conformorph_field", None) == "anchors"


def test_baselines_of_a_mesh_of_several_components() -> None:
    import numpy as np

    from conformorph.pipelines.morph2d.metrics import baseline_metrics

    S = np.array([[0.0, 0], [1, 0], [0, 1], [5, 0], [6, 0], [5, 1]])
    F = np.array([[0, 1, 2], [3, 4, 5]])
    T = S * 1.5 + [0.2, 0.1]
    m = baseline_metrics(S, T, F, np.linspace(0, 1, 5))  # one ARAP system was singular
    assert m["arap"]["total_flipped"] == 0 and m["linear"]["total_flipped"] == 0


FACE = (
    '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 40 24"><path fill-rule="evenodd" '
    'd="M12 2a10 10 0 1 0 0 20a10 10 0 1 0 0-20z M8.5 8a1.5 2 0 1 0 0 4a1.5 2 0 1 0 0-4z '
    'M15.5 8a1.5 2 0 1 0 0 4a1.5 2 0 1 0 0-4z M8 17 a5 4 0 0 1 8 0 l-1 0.8 a4 3 0 0 0 -6 0z"/>'
    '<rect x="30" y="10" width="4" height="4"/></svg>'
)
CHEVRON = (
    '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 40 24">'
    '<path d="M7 4 L9 2 L19 12 L9 22 L7 20 L15 12 Z"/><rect x="30" y="9" width="5" height="5"/></svg>'
)


@pytest.mark.timeout(180)
def test_a_pair_the_strain_method_cannot_mesh_shrinks_and_grows_instead(tmp_path: Path) -> None:
    # a face with three holes -> a chevron: the holes' cuts meet (HoleCorrespondenceError)
    (tmp_path / "a.svg").write_text(FACE)
    (tmp_path / "b.svg").write_text(CHEVRON)
    m = run_morph2d(tmp_path / "a.svg", tmp_path / "b.svg", None, tmp_path / "o")
    parts = m["parts"]
    assert parts["fallback_pairs"] == 1
    face = parts["pairs"][0]
    assert face["separated"] and "HoleCorrespondenceError" in face["fallback"]
    assert not parts["pairs"][1]["separated"]  # the squares still morph
    assert parts["overlapping_frames"] == 0 and m["methods"]["strain"]["total_flipped"] == 0
    assert m["reached_target"]
    # the chevron's speck waits where the shrinking face never passes (at its own pole,
    # in the face's eye, the face swept over it in three frames)
    _assert_parts_apart(tmp_path / "o")


DOT = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 40 24"><circle cx="36" cy="12" r="2"/></svg>'
BADGE = (
    '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 40 24"><circle cx="36" cy="12" r="2"/>'
    '<path fill-rule="evenodd" d="M2 2 H26 V22 H2 Z M5 5 H23 V19 H5 Z"/>'
    '<path d="M7 7 H13 V17 H7 Z"/></svg>'  # a letter in the badge's hole, off its centre
)


@pytest.mark.timeout(120)
def test_parts_growing_inside_each_other_grow_as_one(tmp_path: Path) -> None:
    (tmp_path / "a.svg").write_text(DOT)
    (tmp_path / "b.svg").write_text(BADGE)
    # the dot stays a dot (pinned: unpinned it would become the badge, the whole shape's
    # centre); the badge (part 0) and its letter (part 1) grow
    pin = {"anchors": [[[34.0, -12.0], [34.0, -12.0]]], "parts": [[0, 2]]}
    (tmp_path / "anchors.json").write_text(json.dumps(pin))
    m = run_morph2d(
        tmp_path / "a.svg", tmp_path / "b.svg", tmp_path / "anchors.json", tmp_path / "o"
    )
    parts = m["parts"]
    assert parts["matching"]["pairs"] == [[0, 2]] and parts["matching"]["unmatched_target"] == [
        0,
        1,
    ]
    # scaled about their own poles the letter and the badge cross while growing together
    # (a later schedule had to keep them apart); as one group they never meet, and the
    # first schedule is kept
    assert parts["schedule"] == "together"
    assert parts["overlapping_frames"] == 0 and parts["self_crossing_frames"] == 0
    assert m["methods"]["strain"]["total_flipped"] == 0


def _assert_parts_apart(outdir: Path) -> None:
    """No two parts of any frame of ``outdir/frames.json`` share area."""
    for frame in json.loads((outdir / "frames.json").read_text())["frames"]:
        polys = _frame_polygons(frame)
        assert all(
            polys[i].intersection(polys[j]).area == 0.0 for i in range(len(polys)) for j in range(i)
        ), frame["t"]


def _morph_svgs(tmp_path: Path, source: str, target: str) -> dict:
    """``run_morph2d`` of two SVG texts without anchors, written under ``tmp_path/o``."""
    (tmp_path / "a.svg").write_text(source)
    (tmp_path / "b.svg").write_text(target)
    return run_morph2d(tmp_path / "a.svg", tmp_path / "b.svg", None, tmp_path / "o")


def _frame_polygons(frame: dict) -> list:
    """A frames.json frame's parts as shapely polygons (its paths are M/L polylines)."""
    import re

    import shapely

    def ring(d: str) -> list[tuple[float, float]]:
        return [(float(x), float(y)) for x, y in re.findall(r"(-?[\d.e+-]+),(-?[\d.e+-]+)", d)]

    return [
        shapely.Polygon(ring(p["outline"]), [ring(h) for h in p["holes"]]) for p in frame["parts"]
    ]


@pytest.mark.timeout(120)
def test_a_vanished_part_rests_beside_the_other_shape_not_inside_it(tmp_path: Path) -> None:
    # the disk (7, 12) r 4 has no partner: its own pole is inside the ellipse (x 3..21,
    # y 7..17), so shrunk into it its speck would lie in the target's part in the last
    # frames; it shrinks into the crescent of the disk the ellipse leaves (x < 5)
    import shapely

    (tmp_path / "a.svg").write_text(TWO)
    (tmp_path / "b.svg").write_text(ONE)
    m = run_morph2d(tmp_path / "a.svg", tmp_path / "b.svg", None, tmp_path / "o")
    assert m["parts"]["matching"]["unmatched_source"] == [1]
    frames = json.loads((tmp_path / "o" / "frames.json").read_text())["frames"]
    for frame in frames:
        polys = _frame_polygons(frame)
        assert len(polys) == 2 and all(p.is_valid for p in polys)
        assert polys[0].intersection(polys[1]).area == 0.0, frame["t"]
    speck = _frame_polygons(frames[-1])[1]
    assert speck.area < 1e-4 and shapely.Point(7, 12).distance(speck) > 2.0  # not at (7, 12)
    assert m["parts"]["overlapping_frames"] == 0


def test_a_covered_part_vanishes_at_the_nearest_free_point() -> None:
    import numpy as np
    import shapely

    from conformorph.pipelines.morph2d.growth_schedules import FREE_POLE_MARGIN, _free_point

    square = shapely.box(0.0, 0.0, 1.0, 1.0)
    centre = np.array([0.5, 0.5])
    # the right half is free: its pole, inside the part
    c = _free_point(square, shapely.box(-1.0, -1.0, 0.5, 2.0), centre, 1.0)
    free = shapely.box(0.5, 0.0, 1.0, 1.0)
    assert free.boundary.distance(shapely.Point(c)) == pytest.approx(0.25, abs=1e-2)
    # covered whole (a part in the other parts' way all the while): the nearest point
    # beside what covers it, twice the margin away, not the centre inside it
    cover = shapely.box(-1.0, -0.2, 2.0, 3.0)
    c = _free_point(square, cover, centre, 1.0)
    assert cover.distance(shapely.Point(c)) == pytest.approx(2 * FREE_POLE_MARGIN, rel=1e-6)
    np.testing.assert_allclose(c, [0.5, -0.2 - 2 * FREE_POLE_MARGIN], atol=1e-9)
    # nothing in the way: the part's own pole
    np.testing.assert_allclose(_free_point(square, shapely.Polygon(), centre, 1.0), centre)


RING_AROUND_SQUARE = (
    '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><path fill-rule="evenodd" '
    'd="M12 1a11 11 0 1 0 0 22a11 11 0 1 0 0-22zM12 2a10 10 0 1 1 0 20a10 10 0 1 1 0-20z"/>'
    '<rect x="6" y="6" width="12" height="12"/></svg>'
)
SQUARE_INSIDE = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 24 24"><rect x="7" y="6" width="11" height="13"/></svg>'


@pytest.mark.timeout(180)
def test_the_last_pair_is_separated_when_a_part_around_it_vanishes(tmp_path: Path) -> None:
    # the ring has no partner and must shrink, but the square in its hole morphs: a
    # loop around the square cannot shrink to a point without passing over it (its
    # winding number about it goes from 1 to 0), so only the square shrinking with it (the
    # pair separated, the two scaled as one group) keeps the frames clean
    m = _morph_svgs(tmp_path, RING_AROUND_SQUARE, SQUARE_INSIDE)
    parts = m["parts"]
    # parts by area: the square is 0 and takes the target's, the thin ring (1) is left over
    assert parts["matching"]["unmatched_source"] == [1]
    assert parts["pairs"][0]["separated"] and "fallback" not in parts["pairs"][0]
    assert parts["overlapping_frames"] == 0 and parts["self_crossing_frames"] == 0
    assert m["methods"]["strain"]["total_flipped"] == 0 and m["reached_target"]
    _assert_parts_apart(tmp_path / "o")


FACE_ALONE = FACE.replace('<rect x="30" y="10" width="4" height="4"/>', "")
CHEVRON_ALONE = CHEVRON.replace('<rect x="30" y="9" width="5" height="5"/>', "")


@pytest.mark.timeout(180)
def test_a_one_part_pair_that_cannot_morph_shrinks_and_grows_without_anchors(
    tmp_path: Path,
) -> None:
    m = _morph_svgs(tmp_path, FACE_ALONE, CHEVRON_ALONE)
    parts = m["parts"]
    assert parts["source_parts"] == parts["target_parts"] == 1
    (pair,) = parts["pairs"]
    assert pair["separated"] and "HoleCorrespondenceError" in pair["fallback"]
    assert parts["overlapping_frames"] == 0 and parts["self_crossing_frames"] == 0
    assert m["methods"]["strain"]["total_flipped"] == 0 and m["reached_target"]
    frames = json.loads((tmp_path / "o" / "frames.json").read_text())["frames"]
    assert len(frames) == m["frames"] and all(len(f["parts"]) == 2 for f in frames)
    # with anchors the failure is the user's to see: no fallback
    anchors = {"anchors": [[[2.5, -12.0], [7.5, -4.5]], [[21.5, -12.0], [18.5, -12.0]]]}
    (tmp_path / "anchors.json").write_text(json.dumps(anchors))
    with pytest.raises(ValueError, match="hole 1 of the source has no partner"):
        run_morph2d(
            tmp_path / "a.svg", tmp_path / "b.svg", tmp_path / "anchors.json", tmp_path / "p"
        )


# two spiky 40-point outlines (random radial curves, rounded to 0.1) whose strain morph
# reaches the target with no triangle flipped while the outline crosses itself in 32 of 60
# frames: the spike at the top right swings through its neighbours
SPIKY_A = [[5.4,0.0],[6.8,1.1],[8.9,2.9],[11.4,5.8],[13.5,9.8],[13.9,13.9],[11.7,16.2],[7.5,14.6],[3.0,9.3],[0.4,2.8],[0.0,1.5],[-0.2,1.5],[-1.6,5.0],[-5.4,10.7],[-10.0,13.7],[-13.0,13.0],[-13.3,9.6],[-10.9,5.6],[-7.3,2.4],[-3.9,0.6],[-2.2,0.0],[-3.0,-0.5],[-6.1,-2.0],[-9.6,-4.9],[-11.7,-8.5],[-11.3,-11.3],[-8.9,-12.2],[-5.9,-11.5],[-3.3,-10.2],[-1.5,-9.5],[-0.0,-9.4],[1.6,-9.8],[3.2,-10.0],[4.9,-9.7],[6.3,-8.7],[7.1,-7.1],[7.0,-5.1],[6.1,-3.1],[5.2,-1.7],[4.9,-0.8]]  # fmt: skip
SPIKY_B = [[1.5,0.0],[9.9,1.6],[19.7,6.4],[22.5,11.5],[17.5,12.7],[9.0,9.0],[2.8,3.8],[0.9,1.7],[1.3,3.9],[1.2,7.7],[0.0,9.3],[-1.3,8.2],[-2.3,7.2],[-4.4,8.6],[-8.4,11.6],[-12.7,12.7],[-13.8,10.0],[-9.8,5.0],[-3.6,1.2],[-1.5,0.2],[-3.5,0.0],[-11.0,-1.7],[-17.0,-5.5],[-17.0,-8.7],[-11.6,-8.4],[-5.0,-5.0],[-1.3,-1.8],[-1.1,-2.2],[-2.1,-6.4],[-1.8,-11.2],[-0.0,-13.3],[2.0,-12.4],[3.5,-10.7],[5.4,-10.6],[8.5,-11.8],[11.5,-11.5],[11.3,-8.2],[6.4,-3.3],[1.4,-0.5],[1.5,-0.2]]  # fmt: skip


@pytest.mark.timeout(120)
def test_a_one_part_morph_whose_outline_crosses_shrinks_and_grows_without_anchors(
    tmp_path: Path,
) -> None:
    (tmp_path / "a.json").write_text(json.dumps({"rings": [SPIKY_A]}))
    (tmp_path / "b.json").write_text(json.dumps({"rings": [SPIKY_B]}))
    m = run_morph2d(tmp_path / "a.json", tmp_path / "b.json", None, tmp_path / "o")
    (pair,) = m["parts"]["pairs"]
    assert pair["separated"] and "outline crosses itself in" in pair["fallback"]
    assert m["parts"]["self_crossing_frames"] == 0 and m["parts"]["overlapping_frames"] == 0
    assert m["reached_target"] and m["methods"]["strain"]["total_flipped"] == 0
    # with anchors the strain path is kept, and its crossings are reported
    anchors = {"anchors": [[SPIKY_A[i], SPIKY_B[i]] for i in (0, 10, 20, 30)]}
    (tmp_path / "anchors.json").write_text(json.dumps(anchors))
    m = run_morph2d(
        tmp_path / "a.json", tmp_path / "b.json", tmp_path / "anchors.json", tmp_path / "p"
    )
    assert "parts" not in m and m["reached_target"]
    assert m["crossings"]["self_crossing_frames"] > 0
