"""Holes that one shape has and the other lacks: a small seed hole grows into each of them."""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ._typing import FloatArray

if TYPE_CHECKING:  # scipy.interpolate (and scipy.optimize with it) costs 0.2-0.35 s to import
    from scipy.interpolate import RBFInterpolator
from .shape_rings import (
    HoleCorrespondenceError,
    ShapeRings,
    distance_to_rings,
    points_in_shape,
    ring_signed_area,
)
from .tolerances import HOLE_SEED_RADIUS_FRACTION


@dataclass(frozen=True)
class SeededHole:
    """One hole added to a shape so that both shapes have as many holes.

    Attributes
    ----------
    side : str
        ``"source"`` or ``"target"``: the shape that got the seed.
    hole : int
        Index of the seed among that shape's holes in the returned order (equal
        to the index of the hole it grows into in the other shape).
    partner : int
        Index of that hole in the other shape's *input* hole order.
    centre : (2,) float64
    radius : float
    moved : float
        Distance from where the anchors map the partner's centroid to the seed's
        centre (non-zero when that point is not deep inside the material).
    """

    side: str
    hole: int
    partner: int
    centre: FloatArray
    radius: float
    moved: float


@dataclass(frozen=True)
class HoleSeeding:
    """Result of :func:`seed_missing_holes`.

    Attributes
    ----------
    source, target : ShapeRings
        The shapes with equally many holes, hole i of the source corresponding to
        hole i of the target.
    seeds : tuple of SeededHole
        The holes that were added (empty when both shapes had as many holes; the
        holes are then still put in corresponding order).
    """

    source: ShapeRings
    target: ShapeRings
    seeds: tuple[SeededHole, ...]


def _anchor_map(src: FloatArray, dst: FloatArray) -> RBFInterpolator | None:
    """Thin-plate map of the plane taking anchor points ``src`` to ``dst`` (None: too few)."""
    if (
        src.shape[0] < 3
        or abs(np.linalg.det(np.c_[src[:3], np.ones(3)])) < 1e-12 * np.ptp(src) ** 2
    ):
        return None
    from scipy.interpolate import RBFInterpolator

    return RBFInterpolator(src, dst, kernel="thin_plate_spline", degree=1)


def _map_points(
    f: RBFInterpolator | None, src: FloatArray, dst: FloatArray, p: FloatArray
) -> FloatArray:
    if f is not None:
        return np.asarray(f(p), dtype=np.float64)
    # fewer than three usable anchors: the bounding boxes' affine correspondence
    lo_s, span_s = src.min(axis=0), np.maximum(np.ptp(src, axis=0), 1e-300)
    lo_d, span_d = dst.min(axis=0), np.ptp(dst, axis=0)
    return np.asarray(lo_d + (p - lo_s) / span_s * span_d, dtype=np.float64)


def _seed_site(
    shape: ShapeRings, wanted: FloatArray, avoid: list[tuple[FloatArray, float]]
) -> tuple[FloatArray, float]:
    """A point of ``shape``'s material near ``wanted`` with room for a seed, and that room.

    Candidates are a grid over the shape; those whose clearance (distance to every
    ring and to seeds already placed) is at least half the largest clearance found
    compete, and the one nearest ``wanted`` wins.
    """
    lo, hi = shape.outer.min(axis=0), shape.outer.max(axis=0)
    k = 96
    gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], k), np.linspace(lo[1], hi[1], k))
    cand = np.c_[gx.ravel(), gy.ravel()]
    cand = np.vstack([wanted[None, :], cand])
    inside = points_in_shape(shape, cand)
    cand = cand[inside]
    if cand.shape[0] == 0:
        raise HoleCorrespondenceError("no room inside the shape for a seed hole")
    clear = distance_to_rings(shape, cand)
    for c, r in avoid:
        clear = np.minimum(clear, np.linalg.norm(cand - c, axis=1) - r)
    ok = clear >= 0.5 * float(clear.max())
    best = int(np.argmin(np.where(ok, np.linalg.norm(cand - wanted, axis=1), np.inf)))
    return cand[best], float(clear[best])


def seed_missing_holes(
    source: ShapeRings,
    target: ShapeRings,
    anchors: FloatArray,
    *,
    seed_vertices: int = 8,
    pairing_rank: int = 0,
) -> HoleSeeding:
    """Pair the holes of two shapes, adding a small seed hole where one shape has fewer.

    A morph between shapes with different numbers of holes changes topology; the
    paper's dissection into corresponding patches (its Fig. 6, A → B) implicitly
    opens the missing hole from a slit. Here the missing hole opens from a small
    regular polygon instead, so that the rest of the pipeline (one disk patch per
    shape, straight cuts per hole pair) applies unchanged: at t = 0 the shape that
    lacks the hole carries a seed of radius ``HOLE_SEED_RADIUS_FRACTION`` of the room
    around it (at most 2 % of ``sqrt(2 × area)`` of its outer ring, the diagonal of a
    square of that area), which the strain morph grows
    into the other shape's hole.

    Holes are paired through the anchors: a thin-plate map of the plane that takes
    the source anchors to the target anchors carries every source hole's centroid
    to the target, and the assignment of smallest total distance pairs them. An
    unpaired hole's centroid is carried back into the other shape by the inverse
    map; if that point has little room around it (or lies outside the material),
    the seed moves to the nearest point with at least half the shape's largest
    clearance (reported as ``moved``).

    Parameters
    ----------
    source, target : ShapeRings
    anchors : (a, 2, 2) float64
        ``anchors[i] = [[x_s, y_s], [x_t, y_t]]``.
    seed_vertices : int
        Vertices of each seed polygon (≥ 3).
    pairing_rank : int
        0 for the cheapest pairing of holes, 1 for the next one, …: for a caller
        whose next step cannot use a pairing (e.g. the holes' cuts to the outer
        ring would cross); up to 6 holes on the side with fewer.

    Returns
    -------
    HoleSeeding

    Raises
    ------
    HoleCorrespondenceError
        If a shape has no room for a seed hole, or there is no pairing of rank
        ``pairing_rank``.
    ValueError
        For malformed anchors or ``seed_vertices < 3``.

    Examples
    --------
    A square and the same square with a hole: the plain square gets a seed hole
    where the other has its hole.

    >>> import numpy as np
    >>> from conformorph.geometry.shape_rings import validate_rings
    >>> sq = np.array([[0.0, 0], [4, 0], [4, 4], [0, 4]])
    >>> hole = np.array([[2.5, 1.5], [2.5, 2.5], [3.5, 2.5], [3.5, 1.5]])
    >>> anchors = np.stack([sq, sq], axis=1)
    >>> out = seed_missing_holes(validate_rings([sq]), validate_rings([sq, hole]), anchors)
    >>> len(out.source.holes), out.seeds[0].side, np.round(out.seeds[0].centre, 1).tolist()
    (1, 'source', [3.0, 2.0])
    """
    anchors = np.asarray(anchors, dtype=np.float64)
    if anchors.ndim != 3 or anchors.shape[1:] != (2, 2):
        raise ValueError(f"anchors must have shape (a, 2, 2), got {anchors.shape}")
    if seed_vertices < 3:
        raise ValueError(f"seed_vertices must be at least 3, got {seed_vertices}")
    if pairing_rank < 0:
        raise ValueError(f"pairing_rank must be non-negative, got {pairing_rank}")
    a_s, a_t = anchors[:, 0], anchors[:, 1]
    fwd, back = _anchor_map(a_s, a_t), _anchor_map(a_t, a_s)
    hp = seeded_hole_pairing(source, target, anchors, pairing_rank)
    few_is_source, pairing = hp.few_is_source, hp.pairing
    # order: the many-holes shape keeps its order; the other's holes go where they pair
    few_shape = source if few_is_source else target
    many_shape = target if few_is_source else source
    n_many = len(many_shape.holes)
    slots: list[FloatArray | None] = [None] * n_many
    for i, j in enumerate(pairing):
        slots[j] = few_shape.holes[i]
    seeds: list[SeededHole] = []
    placed: list[tuple[FloatArray, float]] = [(h.mean(axis=0), 0.0) for h in few_shape.holes]
    for j in range(n_many):
        if slots[j] is not None:
            continue
        centre_many = many_shape.holes[j].mean(axis=0)[None, :]
        if few_is_source:
            wanted = _map_points(back, a_t, a_s, centre_many)[0]
        else:
            wanted = _map_points(fwd, a_s, a_t, centre_many)[0]
        try:
            slots[j], site, radius = seed_hole(few_shape, wanted, placed, seed_vertices)
        except HoleCorrespondenceError:
            raise HoleCorrespondenceError(
                f"hole {j} of the {'target' if few_is_source else 'source'} has no partner and "
                f"there is no room for a seed hole in the {'source' if few_is_source else 'target'}"
            ) from None
        placed.append((site, radius))
        seeds.append(
            SeededHole(
                side="source" if few_is_source else "target",
                hole=j,
                partner=j,
                centre=site,
                radius=float(radius),
                moved=float(np.linalg.norm(site - wanted)),
            )
        )
    holes = tuple(h for h in slots if h is not None)
    fixed = ShapeRings(few_shape.outer, holes, few_shape.fixes)
    new_source, new_target = (fixed, target) if few_is_source else (source, fixed)
    return HoleSeeding(new_source, new_target, tuple(seeds))


@dataclass(frozen=True)
class HolePairing:
    """Which hole of the shape with more holes each hole of the other shape pairs with.

    Attributes
    ----------
    few_is_source : bool
        Whether the source is the shape with fewer (or as many) holes.
    pairing : list of int
        For each hole of that shape, its partner in the other.
    cost : (k_few, k_many) float64
        Pairing cost: distance after mapping each way through the anchors,
        relative to each shape's size.
    """

    few_is_source: bool
    pairing: list[int]
    cost: FloatArray


def seeded_hole_pairing(
    source: ShapeRings, target: ShapeRings, anchors: FloatArray, pairing_rank: int = 0
) -> HolePairing:
    """Pair the holes through the anchors: the assignment of rank ``pairing_rank`` by total cost.

    A thin-plate map of the plane taking the source anchors to the target
    anchors carries each source hole's centroid to the target (and the inverse
    map the target's back); the cost of pairing source hole i with target hole
    j is the sum of the two distances, each relative to ``sqrt(2 × area)`` of
    the shape it is measured in, so that swapping the shapes swaps the pairing.

    Parameters
    ----------
    source, target : ShapeRings
    anchors : (a, 2, 2) float64
    pairing_rank : int, optional
        0 for the cheapest pairing (ranked over all pairings for up to 6 holes
        on the side with fewer; optimal assignment beyond).

    Returns
    -------
    HolePairing

    Raises
    ------
    HoleCorrespondenceError
        No pairing of that rank.
    """
    a_s, a_t = anchors[:, 0], anchors[:, 1]
    fwd, back = _anchor_map(a_s, a_t), _anchor_map(a_t, a_s)
    cs = np.array([h.mean(axis=0) for h in source.holes]).reshape(-1, 2)
    ct = np.array([h.mean(axis=0) for h in target.holes]).reshape(-1, 2)
    few_is_source = cs.shape[0] <= ct.shape[0]
    size_s = float(np.sqrt(2.0 * abs(ring_signed_area(source.outer))))
    size_t = float(np.sqrt(2.0 * abs(ring_signed_area(target.outer))))
    if cs.size and ct.size:
        d_t = _map_points(fwd, a_s, a_t, cs)[:, None, :] - ct[None, :, :]
        d_s = cs[:, None, :] - _map_points(back, a_t, a_s, ct)[None, :, :]
        st = np.linalg.norm(d_t, axis=2) / size_t + np.linalg.norm(d_s, axis=2) / size_s
    else:
        st = np.zeros((cs.shape[0], ct.shape[0]))
    cost = st if few_is_source else st.T
    n_many = (ct if few_is_source else cs).shape[0]
    n_few = cost.shape[0]
    if n_few <= 6:
        ranked = sorted(
            itertools.permutations(range(n_many), n_few),
            key=lambda perm: sum(float(cost[i, j]) for i, j in enumerate(perm)),
        )
        if pairing_rank >= len(ranked):
            raise HoleCorrespondenceError(
                f"there are only {len(ranked)} ways to pair the holes (asked for number "
                f"{pairing_rank + 1})"
            )
        pairing = list(ranked[pairing_rank])
    elif pairing_rank:
        raise HoleCorrespondenceError("alternative hole pairings are tried for up to 6 holes")
    else:
        from scipy.optimize import linear_sum_assignment

        rows, cols = linear_sum_assignment(cost)
        pairing = [int(c) for _, c in sorted(zip(rows, cols, strict=True))]
    return HolePairing(few_is_source, pairing, np.asarray(cost, dtype=np.float64))


def seed_hole(
    shape: ShapeRings,
    wanted: FloatArray,
    placed: list[tuple[FloatArray, float]],
    seed_vertices: int = 8,
) -> tuple[FloatArray, FloatArray, float]:
    """A small clockwise regular polygon, a seed hole, in ``shape`` at (or near) ``wanted``.

    Its radius is ``HOLE_SEED_RADIUS_FRACTION`` of the room around the site, at
    most 2 % of ``sqrt(2 × area)`` of the outer ring (the diagonal of a square
    of that area, which does not depend on orientation).

    Parameters
    ----------
    shape : ShapeRings
    wanted : (2,) float64
        Where the seed should be.
    placed : list of ((2,) float64, float)
        Centres and radii of the holes and seeds already there.
    seed_vertices : int, optional

    Returns
    -------
    ring : (seed_vertices, 2) float64
        Clockwise.
    site : (2,) float64
        Its centre (moved from ``wanted`` when there is little room there).
    radius : float

    Raises
    ------
    HoleCorrespondenceError
        No room for a seed.
    """
    size = float(np.sqrt(2.0 * abs(ring_signed_area(shape.outer))))
    site, room = _seed_site(shape, wanted, placed)
    radius = min(HOLE_SEED_RADIUS_FRACTION * room, 0.02 * size)
    if not radius > 1e-9 * size:
        raise HoleCorrespondenceError("there is no room for a seed hole")
    theta = -2.0 * np.pi * np.arange(seed_vertices) / seed_vertices  # clockwise
    return site + radius * np.c_[np.cos(theta), np.sin(theta)], site, float(radius)
