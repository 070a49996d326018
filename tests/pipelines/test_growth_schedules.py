"""growth_schedules: the last-resort points beside all parts (``_aside``), hand-worked and
as an invariant (a shape that dissolves as a whole never crosses in a separated schedule)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from conformorph.geometry.shape_rings import validate_rings
from conformorph.pipelines.morph2d.frame_crossings import crossing_frames
from conformorph.pipelines.morph2d.growth_schedules import (
    ASIDE_GAP,
    SEPARATED_SCHEDULES,
    _aside,
    _assemble,
    _grouped,
    best_schedule,
    lone_part,
    settled_schedule,
)


def _lone(polys: list[shapely.Polygon], grows: bool, side: str) -> dict:
    """Each polygon as a lone part of ``side`` (its own mesh, its own pole)."""
    out = {}
    for i, p in enumerate(polys):
        rings = [np.asarray(p.exterior.coords)[:-1]] + [
            np.asarray(r.coords)[:-1] for r in p.interiors
        ]
        out[(side, i)] = (*lone_part(validate_rings(rings)), grows)
    return out


def test_aside_points_lie_left_and_right_of_every_part() -> None:
    lone = _lone([shapely.box(0.0, 0.0, 10.0, 4.0)], False, "s")
    lone |= _lone([shapely.box(2.0, 1.0, 3.0, 2.0)], True, "t")
    out = _aside([], [], lone)
    gap = ASIDE_GAP * 10.0  # the extent is the box's width
    np.testing.assert_allclose(out[("s", 0)][2], [-gap, 2.0])
    np.testing.assert_allclose(out[("t", 0)][2], [10.0 + gap, 2.0])
    # meshes and sides unchanged
    assert out[("s", 0)][0] is lone[("s", 0)][0] and out[("t", 0)][3] is True


def _ring(cx: float, cy: float, r_out: float, r_in: float) -> shapely.Polygon:
    outer = shapely.Point(cx, cy).buffer(r_out, quad_segs=8)
    return outer.difference(shapely.Point(cx, cy).buffer(r_in, quad_segs=8))


@pytest.mark.parametrize("seed", range(4))
def test_a_shape_dissolving_as_a_whole_is_clean_aside(seed: int) -> None:
    # each side: a ring with a square in its hole and a bar across, at random places over
    # the other side's parts, so that shrinking and growing in place overlap
    rng = np.random.default_rng(seed)
    sides = []
    for _ in range(2):
        cx, cy = rng.uniform(4.0, 6.0, 2)
        ring = _ring(cx, cy, 4.0, 3.0)
        inner = shapely.box(cx - 1.0, cy - 1.0, cx + 1.0, cy + 1.0)
        bar = shapely.box(cx - 6.0, cy + 4.5, cx + 6.0, cy + 5.5 + rng.uniform(0, 1))
        sides.append([ring, inner, bar])
    lone = _lone(sides[0], False, "s") | _lone(sides[1], True, "t")
    times = np.linspace(0.0, 1.0, 30)
    aside = _aside([], [], lone)
    for name in SEPARATED_SCHEDULES:  # the guarantee: every separated schedule is clean
        frames, F = _assemble([], _grouped(aside), times, name)
        c = crossing_frames(frames, F, times)
        assert (c["overlapping_frames"], c["self_crossing_frames"]) == (0, 0), name
        np.testing.assert_allclose(frames[0, : len(lone[("s", 0)][0])], lone[("s", 0)][0])
    # growing in place is not: the search needs the last resort, and ends clean
    in_place = best_schedule([], [], lone, times)
    assert in_place[4]["shrink_first"]["overlapping_frames"] > 0
    assert settled_schedule([], [], lone, times)[0] == (0, 0)
