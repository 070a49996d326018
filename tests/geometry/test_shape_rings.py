"""Tests of conformorph.geometry.shape_rings."""

import numpy as np
import pytest

from conformorph.geometry.shape_rings import (
    AnchorOutsideShapeError,
    DuplicateAnchorError,
    SelfIntersectingRingError,
    ShapeError,
    check_anchors,
    points_in_shape,
    ring_signed_area,
    validate_rings,
)

SQUARE = np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]])
HOLE = np.array([[1.0, 1], [1, 3], [3, 3], [3, 1]])  # clockwise


def test_hand_worked_area_and_orientation_fix_reported():
    assert ring_signed_area(SQUARE) == 16.0
    s = validate_rings([SQUARE[::-1], HOLE[::-1]])
    assert ring_signed_area(s.outer) == 16.0 and ring_signed_area(s.holes[0]) == -4.0
    assert s.area == 12.0
    assert any("outer ring: orientation reversed" in f for f in s.fixes)
    assert any("hole 1: orientation reversed" in f for f in s.fixes)
    assert validate_rings([SQUARE, HOLE]).fixes == ()


def test_closing_point_dropped():
    s = validate_rings([np.vstack([SQUARE, SQUARE[:1]])])
    assert s.outer.shape == (4, 2) and s.fixes


def test_self_intersections_and_bad_holes_are_named():
    bowtie = np.array([[0.0, 0], [2, 2], [2, 0], [0, 2]])
    with pytest.raises(SelfIntersectingRingError, match="intersects itself"):
        validate_rings([bowtie])
    with pytest.raises(SelfIntersectingRingError, match="outside"):
        validate_rings([SQUARE, HOLE + 10])
    with pytest.raises(SelfIntersectingRingError, match="intersect"):
        validate_rings([SQUARE, HOLE + [2.5, 0]])
    with pytest.raises(ShapeError):
        validate_rings([SQUARE[:2]])
    with pytest.raises(ShapeError):
        validate_rings([])


def test_points_in_shape_with_hole_and_boundary():
    s = validate_rings([SQUARE, HOLE])
    P = np.array([[0.5, 0.5], [2.0, 2.0], [5.0, 1.0], [4.0, 2.0], [1.0, 2.0]])
    assert points_in_shape(s, P).tolist() == [True, False, False, True, True]


@pytest.mark.parametrize("scale", [1e-8, 1e8])
def test_scale_and_rotation_invariance(scale):
    th = 0.3
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    s = validate_rings([scale * SQUARE @ R.T, scale * HOLE @ R.T])
    P = scale * np.array([[0.5, 0.5], [2.0, 2.0]]) @ R.T
    assert points_in_shape(s, P).tolist() == [True, False]
    assert s.area == pytest.approx(12 * scale**2)


def test_inputs_not_mutated():
    a, h = SQUARE[::-1].copy(), HOLE.copy()
    c = a.copy(), h.copy()
    validate_rings([a, h])
    assert np.array_equal(a, c[0]) and np.array_equal(h, c[1])


def test_intersection_check_memory_is_not_quadratic():
    # A 6000-point ring (a wavy circle) and a 600-point hole: the k × k segment
    # matrices of a direct test would need gigabytes (k² = 3.6e7 pairs, several
    # float64 arrays); the sweep stays within a few tens of MB.
    import tracemalloc

    k = 6000
    th = np.linspace(0, 2 * np.pi, k, endpoint=False)
    ring = np.c_[np.cos(th), np.sin(th)] * (1 + 0.1 * np.sin(7 * th))[:, None]
    hole = 0.3 * np.c_[np.cos(th[::10]), -np.sin(th[::10])]
    tracemalloc.start()
    try:
        s = validate_rings([ring, hole])
        inside = points_in_shape(s, np.zeros((500, 2)) + [0.5, 0.0])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert s.outer.shape == (k, 2) and inside.all()
    assert peak < 64e6, f"peak {peak / 1e6:.0f} MB"
    # and a crossing is still found among the many edges
    bad = ring.copy()
    bad[[10, 3010]] = bad[[3010, 10]]
    with pytest.raises(SelfIntersectingRingError, match="intersects itself"):
        validate_rings([bad])


def test_crossing_count_matches_the_direct_pairwise_test():
    # the sweep must find exactly the pairs the all-pairs test finds, touching and
    # collinear cases included (coordinates on a coarse grid make many of them)
    from conformorph.geometry.shape_rings import _crossings, _segments_cross

    def direct(a, b, same):
        Pa, Qa, Pb, Qb = a, np.roll(a, -1, 0), b, np.roll(b, -1, 0)
        hits = _segments_cross(Pa[:, None], Qa[:, None], Pb[None], Qb[None])
        if same:
            k = a.shape[0]
            i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
            hits &= (i < j) & ((i + 1) % k != j) & ((j + 1) % k != i)
        return int(hits.sum())

    rng = np.random.default_rng(5)
    for trial in range(150):
        a = rng.random((int(rng.integers(3, 30)), 2))
        b = rng.random((int(rng.integers(3, 30)), 2))
        if trial % 2:
            a, b = np.round(a * 4) / 4, np.round(b * 4) / 4
        assert _crossings(a, a, True) == direct(a, a, True)
        assert _crossings(a, b, False) == direct(a, b, False)


def test_check_anchors_names_the_anchor_and_the_side():
    s = validate_rings([SQUARE, HOLE])
    big = validate_rings([SQUARE * 10])
    check_anchors(s, big, [[[0, 0], [0, 0]], [[4, 4], [40, 40]], [[0.5, 3.5], [5, 35]]])
    # outside: the hole of the source, then the target's outside
    with pytest.raises(AnchorOutsideShapeError, match="anchor 1 .* source") as e:
        check_anchors(s, big, [[[0, 0], [0, 0]], [[2, 2], [20, 20]]])
    assert (e.value.index, e.value.side) == (1, 0)
    with pytest.raises(AnchorOutsideShapeError, match="anchor 0 .* target") as e:
        check_anchors(s, big, [[[0, 0], [-1, 0]], [[4, 4], [40, 40]]])
    assert (e.value.index, e.value.side) == (0, 1)
    # the same source point twice (the target points differ), and the same target point
    with pytest.raises(
        DuplicateAnchorError, match="anchors 0 and 2 are the same source point"
    ) as e:
        check_anchors(s, big, [[[0, 4], [0, 40]], [[4, 4], [40, 40]], [[0, 4], [0, 0]]])
    assert (e.value.index, e.value.side) == (2, 0)
    with pytest.raises(DuplicateAnchorError, match="same target point") as e:
        check_anchors(s, big, [[[0, 4], [0, 40]], [[4, 4], [40, 40]], [[4, 0], [40, 40]]])
    assert (e.value.index, e.value.side) == (2, 1)
    # coincident within the tolerance (relative to the shape's size), distinct beyond it
    d = 4 * np.sqrt(2)
    close = [[[1, 0.5], [10, 5]], [[1 + 0.5e-6 * d, 0.5], [20, 5]]]
    with pytest.raises(DuplicateAnchorError):
        check_anchors(s, big, close)
    check_anchors(s, big, close, rtol=1e-7)
    assert issubclass(DuplicateAnchorError, ValueError)


@pytest.mark.parametrize("scale", [1e-8, 1e8])
def test_check_anchors_tolerance_is_relative(scale):
    s = validate_rings([scale * SQUARE])
    a = scale * np.array([[[1, 1], [1, 1]], [[1 + 1e-3, 1], [3, 3]]])
    check_anchors(s, s, a)
    a[1, 0] = scale * np.array([1 + 1e-7, 1])
    with pytest.raises(DuplicateAnchorError):
        check_anchors(s, s, a)


def test_winding_numbers_by_hand_and_invariance() -> None:
    from conformorph.geometry.shape_rings import winding_numbers

    sq = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2]])  # counter-clockwise: +1 inside
    star = np.array([[0.0, 3], [-1.76, -2.43], [2.85, 0.93], [-2.85, 0.93], [1.76, -2.43]])
    P = np.array([[1.0, 1], [3, 3], [0.0, 0.1]])
    before = (sq.copy(), P.copy())
    assert winding_numbers([sq], P).tolist() == [1, 0, 1]
    assert winding_numbers([sq[::-1]], P).tolist() == [-1, 0, -1]
    assert winding_numbers([sq, sq], P).tolist() == [2, 0, 2]
    assert winding_numbers([star], [[0.0, 0.0], [0.0, 2.0]]).tolist() == [2, 1]
    assert np.array_equal(sq, before[0]) and np.array_equal(P, before[1])  # not mutated
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s], [s, c]])
    for scale in (1e-8, 1e8):
        moved = [(star @ R.T) * scale + [3.0 * scale, -1.0 * scale]]
        Q = (np.array([[0.0, 0.0], [0.0, 2.0]]) @ R.T) * scale + [3.0 * scale, -1.0 * scale]
        assert winding_numbers(moved, Q).tolist() == [2, 1]


def test_a_hole_touching_the_outline_or_a_hole_is_parted_by_a_hair():
    big = np.array([[0.0, 0], [10, 0], [10, 10], [0, 10]])
    # a triangular hole whose bottom vertex lies on the outline up to rounding
    tri = np.array([[5.0, 1e-15], [3, 5], [7, 5]])  # clockwise
    original = tri.copy()
    s = validate_rings([big, tri])
    # extent 10: the vertex steps 1e-3 * 10 straight into the hole (its bisector)
    np.testing.assert_allclose(s.holes[0][s.holes[0][:, 1] < 1][0], [5.0, 0.01], atol=1e-12)
    assert s.fixes == ("hole 1: moved 1 point(s) touching the outer ring by 0.01",)
    assert np.array_equal(tri, original)  # the input is not moved
    # exactly on the outline: parted too (it was refused as an intersection)
    assert validate_rings([big, np.array([[5.0, 0], [3, 5], [7, 5]])]).fixes
    # the outline's vertex on a hole's edge steps out of the shape, away from the hole
    notch = np.array([[0.0, 0], [10, 0], [10, 10], [5, 2], [0, 10]])
    s = validate_rings([notch, np.array([[3.0, 2], [7, 2], [5, 1]])])
    np.testing.assert_allclose(s.outer[3], [5.0, 2.01], atol=1e-12)
    assert s.fixes == ("outer ring: moved 1 point(s) touching hole 1 by 0.01",)
    # two holes meeting at a vertex: the first steps into itself, which parts them
    left = np.array([[2.0, 5], [2, 8], [5, 5 + 1e-14]])
    right = np.array([[5.0, 5], [8, 8], [8, 5]])
    s = validate_rings([big, left, right])
    assert s.fixes == ("hole 1: moved 1 point(s) touching hole 2 by 0.01",)
    gap = np.linalg.norm(s.holes[0][:, None] - s.holes[1][None], axis=2).min()
    assert gap > 0.005
    # apart by more than the tolerance: nothing moves
    assert validate_rings([big, tri + [0, 1e-6]]).fixes == ()


def test_a_parted_shape_meshes_with_one_boundary_loop_per_ring():
    from conformorph.geometry.boundary_loop import boundary_loops
    from conformorph.geometry.triangulate_shape import triangulate_shape

    # the outline's vertex exactly on the hole's edge (refused as an intersection before)
    notch = np.array([[0.0, 0], [10, 0], [10, 10], [5, 2], [0, 10]])
    s = validate_rings([notch, np.array([[3.0, 2], [7, 2], [5, 1]])])
    _, F = triangulate_shape(s)
    assert len(boundary_loops(F)) == 2


def test_an_outline_pinched_onto_itself_is_parted():
    import shapely

    # two triangular lobes whose tips meet at (5, 2): the ring passes there twice
    for eps in (0.0, 1e-15):
        ring = np.array([[0.0, 0], [5, 2], [10, 0], [10, 4], [5 + eps, 2], [0, 4]])
        s = validate_rings([ring])
        assert s.fixes == ("outer ring: moved 2 point(s) touching itself by 0.01",)
        # each tip steps into its narrower angle (the outside): a bridge 0.02 wide
        np.testing.assert_allclose(s.outer[1], [5.0, 1.99], atol=1e-12)
        np.testing.assert_allclose(s.outer[4], [5.0, 2.01], atol=1e-12)
        assert shapely.LinearRing(s.outer).is_simple
        # scaled to a speck about a far point, the two passes stay apart
        speck = 1e-3 * (s.outer - [50.0, 50.0]) + [50.0, 50.0]
        assert shapely.LinearRing(speck).is_simple
