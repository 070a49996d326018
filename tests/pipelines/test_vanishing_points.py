"""Sweeps, shadows and growth points of parts that grow out of a point (issue 28)."""

from __future__ import annotations

import numpy as np
import shapely

from conformorph.pipelines.morph2d.vanishing_points import growth_points, shadow, sweep

SQUARE = shapely.box(0.0, 0.0, 1.0, 1.0)
# a U opening to the left: the box [2, 5] x [0, 3] less the notch [2, 4] x [1, 2]
U = shapely.box(2.0, 0.0, 5.0, 3.0).difference(shapely.box(1.9, 1.0, 4.0, 2.0))


def test_sweep_by_hand() -> None:
    # about its own centre a convex part sweeps only itself
    assert np.isclose(sweep(SQUARE, np.array([0.5, 0.5])).area, 1.0)
    # about (3, 0.5): the square and the triangle (1, 0), (3, 0.5), (1, 1) of area 1
    far = sweep(SQUARE, np.array([3.0, 0.5]))
    assert np.isclose(far.area, 2.0)
    assert far.contains(shapely.Point(2.5, 0.5)) and not far.contains(shapely.Point(2.5, 0.9))


def test_sweep_holds_every_scaled_copy() -> None:
    rng = np.random.default_rng(3)
    c = np.array([3.0, 1.5])  # in the U's notch: the U's arms sweep over it
    swept = sweep(U, c).buffer(1e-9)
    for s in rng.uniform(0.0, 1.0, 20):
        assert swept.contains(shapely.affinity.scale(U, s, s, origin=tuple(c)))
    assert swept.contains(shapely.Point(3.0, 1.5))


def test_shadow_is_where_growing_passes_over_the_speck() -> None:
    speck = np.array([2.0, 0.5])
    region = shadow(SQUARE, speck, 10.0)
    # by hand: (4, 0.5) = speck + 1 * (speck - (0, 0.5)); the square scaled about it by
    # 2/3 covers x in [4 - 8/3, 4 - 2] = [1.33, 2], the speck among them
    assert region.contains(shapely.Point(4.0, 0.5)) and not region.contains(shapely.Point(2.0, 2.0))
    rng = np.random.default_rng(5)
    for q in rng.uniform(-3.0, 6.0, (80, 2)):
        if SQUARE.contains(shapely.Point(q)):
            continue
        passes = any(
            shapely.affinity.scale(SQUARE, s, s, origin=tuple(q))
            .buffer(1e-9)
            .contains(shapely.Point(speck))
            for s in np.linspace(0.001, 1.0, 300)
        )
        inside = region.buffer(0.02).contains(shapely.Point(q))
        outside = not region.buffer(-0.02).contains(shapely.Point(q))
        assert (passes and inside) or (not passes and outside), q


def test_growth_points_stay_out_of_sweeps_and_shadows() -> None:
    # the U grows; a square shrinks into (3, 1.5), a point in the U's notch: a centre in
    # the U's top arm would grow the bottom arm over that speck
    c = np.array([3.0, 1.5])
    shrinking = [([shapely.box(2.6, 1.1, 3.4, 1.9)], c)]
    (q,) = growth_points([[U]], shrinking, shapely.Polygon(), margin=0.01)
    assert q is not None
    assert not sweep(U, q).buffer(0.005).contains(shapely.Point(c))
    assert not sweep(shrinking[0][0][0], c).contains(shapely.Point(q))
    assert U.contains(shapely.Point(q))  # room in the U itself: it grows in place


def test_growth_points_give_up_when_a_speck_rests_inside() -> None:
    inside = [([shapely.box(4.2, 0.2, 4.8, 0.8)], np.array([4.5, 0.5]))]
    assert growth_points([[U]], inside, shapely.Polygon(), margin=0.01) == [None]
