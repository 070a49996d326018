"""Planar shapes given as polygon rings: validation, orientation repair, point containment.

A shape is an outer ring (counter-clockwise, y up) and any number of holes
(clockwise), each an (k, 2) array whose first point is not repeated at the
end. Input errors each have their own exception type so that the CLI and the
API can name them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._typing import BoolArray, FloatArray, IntArray
from .interval_sweep import SWEEP_BLOCK, x_overlap_pairs
from .mesh_errors import MeshError
from .tolerances import ANCHOR_COINCIDENT_RTOL
from .touching_rings import part_touching_rings


class ShapeError(MeshError):
    """Base class of planar-shape input errors."""

    code = "bad_shape"


class SelfIntersectingRingError(ShapeError):
    """A ring crosses itself or another ring, or a hole lies outside the outer ring."""

    code = "self_intersecting_ring"


class TooFewAnchorsError(ShapeError):
    """Fewer than two anchor pairs were given."""

    code = "too_few_anchors"


class _AnchorError(ShapeError):
    """An error about one anchor point: ``index`` (pair number) and ``side`` (0 source, 1 target)."""

    def __init__(self, message: str, *, index: int | None = None, side: int | None = None):
        super().__init__(message)
        self.index = index
        self.side = side


class AnchorOutsideShapeError(_AnchorError):
    """An anchor point lies outside its shape (``index``, ``side`` say which)."""

    code = "anchor_outside_shape"


class DuplicateAnchorError(_AnchorError):
    """Two anchors are the same point of one shape (``index`` is the later one, ``side`` the shape)."""

    code = "duplicate_anchors"


class PathError(ShapeError):
    """A dissection path (a pair of anchor indices) that is malformed, leaves a shape or crosses
    another; ``index`` is the path's position in the list."""

    code = "bad_path"

    def __init__(self, message: str, index: int) -> None:
        super().__init__(message)
        self.index = index


class HoleCorrespondenceError(ShapeError):
    """The holes of the two shapes cannot be put in correspondence."""

    code = "holes_cannot_correspond"


@dataclass(frozen=True)
class ShapeRings:
    """A validated planar shape.

    Attributes
    ----------
    outer : (k, 2) float64
        Outer ring, counter-clockwise.
    holes : tuple of (k_i, 2) float64
        Hole rings, clockwise.
    fixes : tuple of str
        What was repaired (ring reversed, closing point dropped), for reporting.
    """

    outer: FloatArray
    holes: tuple[FloatArray, ...]
    fixes: tuple[str, ...]

    @property
    def rings(self) -> tuple[FloatArray, ...]:
        """Outer ring followed by the holes."""
        return (self.outer, *self.holes)

    @property
    def area(self) -> float:
        """Enclosed area (outer minus holes)."""
        return float(sum(ring_signed_area(r) for r in self.rings))


def ring_signed_area(ring: FloatArray) -> float:
    """Signed area of a closed polygon (shoelace; positive when counter-clockwise).

    Parameters
    ----------
    ring : (k, 2) float64

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> ring_signed_area(np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]]))
    1.0
    """
    x, y = ring[:, 0], ring[:, 1]
    return float(0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _segments_cross(P: FloatArray, Q: FloatArray, R: FloatArray, S: FloatArray) -> BoolArray:
    """Proper or touching intersection of segments PQ and RS (broadcast)."""

    def orient(a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
        return np.asarray(
            (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1])
            - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])
        )

    d1, d2 = orient(R, S, P), orient(R, S, Q)
    d3, d4 = orient(P, Q, R), orient(P, Q, S)
    proper = (
        ((d1 > 0) != (d2 > 0))
        & ((d3 > 0) != (d4 > 0))
        & (d1 != 0)
        & (d2 != 0)
        & (d3 != 0)
        & (d4 != 0)
    )

    def on_seg(a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray) -> BoolArray:
        return np.asarray(
            (d == 0)
            & (np.minimum(a[..., 0], b[..., 0]) <= c[..., 0])
            & (c[..., 0] <= np.maximum(a[..., 0], b[..., 0]))
            & (np.minimum(a[..., 1], b[..., 1]) <= c[..., 1])
            & (c[..., 1] <= np.maximum(a[..., 1], b[..., 1]))
        )

    touch = on_seg(R, S, P, d1) | on_seg(R, S, Q, d2) | on_seg(P, Q, R, d3) | on_seg(P, Q, S, d4)
    return np.asarray(proper | touch)


def _crossings(a: FloatArray, b: FloatArray, same: bool) -> int:
    """Number of intersecting edge pairs between rings a and b (adjacent edges excluded).

    Memory is O(k + block), not O(k²): candidate pairs come from a sweep over
    the edges' x extents, are filtered by their y extents and then tested
    exactly (:func:`_segments_cross`).
    """
    Pa, Qa = a, np.roll(a, -1, axis=0)
    Pb, Qb = b, np.roll(b, -1, axis=0)
    lo_a, hi_a = np.minimum(Pa, Qa), np.maximum(Pa, Qa)
    lo_b, hi_b = np.minimum(Pb, Qb), np.maximum(Pb, Qb)
    k = a.shape[0]
    total = 0
    for i, j in x_overlap_pairs(lo_a[:, 0], hi_a[:, 0], lo_b[:, 0], hi_b[:, 0]):
        keep = (lo_a[i, 1] <= hi_b[j, 1]) & (lo_b[j, 1] <= hi_a[i, 1])
        if same:
            # each unordered pair once, and not an edge with itself or its neighbours
            keep &= (i < j) & ((i + 1) % k != j) & ((j + 1) % k != i)
        i, j = i[keep], j[keep]
        total += int(np.count_nonzero(_segments_cross(Pa[i], Qa[i], Pb[j], Qb[j])))
    return total


def points_in_ring(ring: FloatArray, P: FloatArray) -> BoolArray:
    """Even-odd test of points against one closed ring.

    Parameters
    ----------
    ring : (k, 2) float64
    P : (p, 2) float64

    Returns
    -------
    inside : (p,) bool
    """
    P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    a, b = ring[None], np.roll(ring, -1, axis=0)[None]
    inside = np.zeros(P.shape[0], dtype=bool)
    step = max(1, SWEEP_BLOCK // max(1, ring.shape[0]))  # bounded memory: p × k in blocks
    for s in range(0, P.shape[0], step):
        x, y = P[s : s + step, 0][:, None], P[s : s + step, 1][:, None]
        cond = (a[..., 1] > y) != (b[..., 1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = a[..., 0] + (y - a[..., 1]) * (b[..., 0] - a[..., 0]) / (b[..., 1] - a[..., 1])
        inside[s : s + step] = np.sum(cond & (x < xc), axis=1) % 2 == 1
    return inside


def winding_numbers(rings: Sequence[ArrayLike], P: ArrayLike) -> IntArray:
    """How many times the rings, together, wind around each point.

    Parameters
    ----------
    rings : sequence of (k_i, 2) array_like
        Closed polygons (last point not repeated), any orientation: each
        counter-clockwise turn counts +1, each clockwise turn -1 (y up).
    P : (p, 2) array_like
        Query points, not on any ring.

    Returns
    -------
    w : (p,) int64
        The winding number (the crossing-number form: an upward edge crossing
        the ray to the right of the point counts +1, a downward one -1). SVG's
        ``fill-rule="nonzero"`` paints where ``w != 0``, ``"evenodd"`` where
        ``w`` is odd (SVG 2, §13.4.2; in SVG's y-down frame the signs flip,
        which changes neither rule).

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2]])
    >>> winding_numbers([sq, sq + 0.5], [[0.25, 0.25], [1, 1], [5, 5]]).tolist()
    [1, 2, 0]
    """
    Q = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    w = np.zeros(Q.shape[0], dtype=np.int64)
    for ring in rings:
        a = np.asarray(ring, dtype=np.float64)
        b = np.roll(a, -1, axis=0)
        step = max(1, SWEEP_BLOCK // max(1, a.shape[0]))
        for s in range(0, Q.shape[0], step):
            x, y = Q[s : s + step, 0][:, None], Q[s : s + step, 1][:, None]
            up = (a[None, :, 1] <= y) & (b[None, :, 1] > y)
            down = (a[None, :, 1] > y) & (b[None, :, 1] <= y)
            # which side of the edge a -> b the point lies on (> 0: left)
            side = (b[None, :, 0] - a[None, :, 0]) * (y - a[None, :, 1]) - (x - a[None, :, 0]) * (
                b[None, :, 1] - a[None, :, 1]
            )
            w[s : s + step] += np.sum(up & (side > 0), axis=1) - np.sum(down & (side < 0), axis=1)
    return w


def distance_to_rings(shape: ShapeRings, P: FloatArray) -> FloatArray:
    """Distance from each point to the nearest boundary edge of the shape.

    Parameters
    ----------
    shape : ShapeRings
    P : (p, 2) float64

    Returns
    -------
    d : (p,) float64
    """
    P = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    best = np.full(P.shape[0], np.inf)
    for r in shape.rings:
        a, b = r, np.roll(r, -1, axis=0)
        e = b - a
        ee = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
        step = max(1, SWEEP_BLOCK // max(1, r.shape[0]))  # bounded memory: p × k in blocks
        for s in range(0, P.shape[0], step):
            dx = P[s : s + step, 0][:, None] - a[None, :, 0]
            dy = P[s : s + step, 1][:, None] - a[None, :, 1]
            t = np.clip((dx * e[:, 0] + dy * e[:, 1]) / ee, 0.0, 1.0)
            dx -= t * e[:, 0]
            dy -= t * e[:, 1]
            d = np.sqrt((dx * dx + dy * dy).min(axis=1))
            best[s : s + step] = np.minimum(best[s : s + step], d)
    return best


def points_in_shape(shape: ShapeRings, P: ArrayLike, *, rtol: float = 1e-9) -> BoolArray:
    """Whether points lie in the closed shape (inside the outer ring, outside every hole).

    Parameters
    ----------
    shape : ShapeRings
    P : (p, 2) float64
    rtol : float, optional
        Points within ``rtol`` × bounding-box diagonal of the boundary count as inside.

    Returns
    -------
    inside : (p,) bool
    """
    Q = np.asarray(P, dtype=np.float64).reshape(-1, 2)
    inside = points_in_ring(shape.outer, Q)
    for h in shape.holes:
        inside &= ~points_in_ring(h, Q)
    diag = float(np.linalg.norm(np.ptp(shape.outer, axis=0)))
    return np.asarray(inside | (distance_to_rings(shape, Q) <= rtol * diag))


def validate_rings(rings: Sequence[ArrayLike]) -> ShapeRings:
    """Check a list of rings and repair orientation.

    Parameters
    ----------
    rings : sequence of (k_i, 2) array_like
        ``rings[0]`` is the outer boundary, the rest are holes; a repeated
        closing point is dropped.

    Returns
    -------
    ShapeRings
        With the outer ring counter-clockwise and holes clockwise, and rings
        that touch one another (or themselves) at a point moved apart by a
        hair (:func:`conformorph.geometry.touching_rings.part_touching_rings`); ``fixes`` says which rings were
        reversed or moved.

    Raises
    ------
    ShapeError
        Empty input, a ring with fewer than 3 distinct points, non-finite
        coordinates, or zero area.
    SelfIntersectingRingError
        A ring crosses itself or another ring, or a hole is not inside the
        outer ring (or inside another hole).

    Notes
    -----
    Edge pairs are found by a sweep over the edges' x extents and tested in
    blocks, so memory stays O(k) per ring pair; time is O(k log k) plus the
    number of edge pairs whose bounding boxes overlap (O(k) for a
    silhouette's boundary, O(k²) only for pathological rings).
    """
    if len(rings) == 0:
        raise ShapeError("a shape needs at least one ring")
    fixes: list[str] = []
    clean: list[FloatArray] = []
    for i, r in enumerate(rings):
        name = "outer ring" if i == 0 else f"hole {i}"
        a = np.asarray(r, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 2:
            raise ShapeError(f"{name} must have shape (k, 2), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ShapeError(f"{name} has non-finite coordinates")
        if a.shape[0] > 1 and np.array_equal(a[0], a[-1]):
            a = a[:-1]
            fixes.append(f"{name}: dropped the repeated closing point")
        keep = np.any(a != np.roll(a, 1, axis=0), axis=1)
        if not np.all(keep):
            fixes.append(f"{name}: dropped {int((~keep).sum())} repeated consecutive points")
            a = a[keep]
        if a.shape[0] < 3:
            raise ShapeError(f"{name} has {a.shape[0]} distinct points, at least 3 are needed")
        area = ring_signed_area(a)
        if area == 0.0:
            n_self = _crossings(a, a, same=True)
            if n_self:  # a bow tie's lobes cancel
                raise SelfIntersectingRingError(
                    f"{name} intersects itself ({n_self} crossing edge pairs)"
                )
            raise ShapeError(f"{name} has zero area")
        want_ccw = i == 0
        if (area > 0) != want_ccw:
            a = a[::-1].copy()
            fixes.append(
                f"{name}: orientation reversed to {'counter-clockwise' if want_ccw else 'clockwise'}"
            )
        clean.append(a)
    fixes += part_touching_rings(clean)
    for i, a in enumerate(clean):
        n_self = _crossings(a, a, same=True)
        if n_self:
            name = "outer ring" if i == 0 else f"hole {i}"
            raise SelfIntersectingRingError(
                f"{name} intersects itself ({n_self} crossing edge pairs)"
            )
    for i in range(len(clean)):
        for j in range(i + 1, len(clean)):
            if _crossings(clean[i], clean[j], same=False):
                raise SelfIntersectingRingError(f"rings {i} and {j} intersect")
    outer = clean[0]
    for i, h in enumerate(clean[1:], start=1):
        if not points_in_ring(outer, h[:1])[0]:
            raise SelfIntersectingRingError(f"hole {i} lies outside the outer ring")
        for j, h2 in enumerate(clean[1:], start=1):
            if j != i and points_in_ring(h2, h[:1])[0]:
                raise SelfIntersectingRingError(f"hole {i} lies inside hole {j}")
    return ShapeRings(outer=outer, holes=tuple(clean[1:]), fixes=tuple(fixes))


def check_anchors(
    source: ShapeRings,
    target: ShapeRings,
    anchors: ArrayLike,
    *,
    rtol: float = ANCHOR_COINCIDENT_RTOL,
) -> None:
    """Check anchor pairs against their shapes: each point inside, no two at one point.

    Parameters
    ----------
    source, target : ShapeRings
    anchors : (a, 2, 2) array_like
        ``anchors[i, 0]`` in the source, ``anchors[i, 1]`` in the target.
    rtol : float, optional
        Points of one shape closer than ``rtol`` × its bounding-box diagonal
        are the same point.

    Raises
    ------
    ValueError
        If ``anchors`` does not have shape (a, 2, 2) or is not finite.
    AnchorOutsideShapeError
        The first anchor (source side first) outside its shape; ``index`` and
        ``side`` say which.
    DuplicateAnchorError
        Two anchors at the same point of the source or of the target (a
        point cannot be pinned to two places, nor two points to one).

    Examples
    --------
    >>> import numpy as np
    >>> sq = validate_rings([np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])])
    >>> check_anchors(sq, sq, [[[0, 0], [0, 0]], [[1, 1], [1, 1]]])
    >>> try:
    ...     check_anchors(sq, sq, [[[0, 0], [0, 0]], [[0, 0], [1, 1]]])
    ... except DuplicateAnchorError as e:
    ...     print(e.index, e.side)
    1 0
    """
    A = np.asarray(anchors, dtype=np.float64)
    if A.ndim != 3 or A.shape[1:] != (2, 2):
        raise ValueError(f"anchors must have shape (a, 2, 2), got {A.shape}")
    if not np.all(np.isfinite(A)):
        raise ValueError("anchors must be finite")
    sides = ((0, source, "source"), (1, target, "target"))
    for side, shape, name in sides:
        inside = points_in_shape(shape, A[:, side])
        if not np.all(inside):
            i = int(np.flatnonzero(~inside)[0])
            raise AnchorOutsideShapeError(
                f"anchor {i} {A[i, side].tolist()} lies outside the {name} shape",
                index=i,
                side=side,
            )
    for side, shape, name in sides:
        P = A[:, side]
        tol = rtol * float(np.linalg.norm(np.ptp(shape.outer, axis=0)))
        # sort by x: coincident points are neighbours within a run of x-width ≤ tol
        order = np.argsort(P[:, 0], kind="stable")
        for lag in range(1, P.shape[0]):
            a, b = order[:-lag], order[lag:]
            near_x = P[b, 0] - P[a, 0] <= tol
            if not np.any(near_x):
                break
            d = np.linalg.norm(P[a] - P[b], axis=1)
            hit = np.flatnonzero(near_x & (d <= tol))
            if hit.size:
                i, j = sorted((int(a[hit[0]]), int(b[hit[0]])))
                raise DuplicateAnchorError(
                    f"anchors {i} and {j} are the same {name} point {P[i].tolist()} "
                    f"(within {rtol:g} of the shape's size): each anchor must be a distinct "
                    "point of both shapes",
                    index=j,
                    side=side,
                )
