"""Dissection paths: the boundary anchors' order, the checked paths, and the polygons they cut.

A path runs from a boundary anchor through interior anchors (straight between
consecutive ones) to another boundary anchor, in both shapes; ``len(paths)``
non-crossing paths cut a disk into ``len(paths) + 1`` patches.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ._typing import BoolArray, FloatArray
from .boundary_anchors import ANCHOR_ON_BOUNDARY_RTOL, _project_on_ring
from .shape_rings import (
    PathError,
    ShapeError,
    ShapeRings,
    _segments_cross,
    distance_to_rings,
    points_in_shape,
)

#: An edge of a patch polygon: (corner anchor, None) runs along the outer ring to
#: the next corner, (corner anchor, path) along a cut (the path oriented forward).
PolygonEdge = tuple[int, tuple[int, ...] | None]


def _chord_inside(shape: ShapeRings, p: FloatArray, q: FloatArray) -> bool:
    """Whether the segment pq, ends excepted, lies inside the shape.

    The segment shrunk by ``ANCHOR_ON_BOUNDARY_RTOL`` of the diagonal at both
    ends must cross no ring segment, and its midpoint must be inside.
    """
    diag = float(np.linalg.norm(np.ptp(shape.outer, axis=0)))
    d = q - p
    eps = ANCHOR_ON_BOUNDARY_RTOL * diag / max(float(np.linalg.norm(d)), 1e-300)
    a0, b0 = p + eps * d, q - eps * d
    for ring in shape.rings:
        a, b = ring, np.roll(ring, -1, axis=0)
        k = a.shape[0]
        if np.any(_segments_cross(np.repeat(a0[None], k, 0), np.repeat(b0[None], k, 0), a, b)):
            return False
    return bool(points_in_shape(shape, (0.5 * (p + q))[None])[0])


def _segments_meet(p: FloatArray, q: FloatArray, r: FloatArray, t: FloatArray) -> bool:
    """Whether segments pq and rt intersect anywhere but at a common end point."""
    shared = [np.array_equal(x, y) for x in (p, q) for y in (r, t)]
    if any(shared):
        # a common end: the segments meet elsewhere only if collinear and overlapping
        d1, d2 = q - p, t - r
        if abs(d1[0] * d2[1] - d1[1] * d2[0]) > 1e-12 * float(
            np.linalg.norm(d1) * np.linalg.norm(d2)
        ):
            return False
        return float(np.dot(d1, d2)) > 0 if (shared[0] or shared[3]) else float(np.dot(d1, d2)) < 0
    return bool(_segments_cross(p, q, r, t))


@dataclass(frozen=True)
class DissectionAnchors:
    """The anchors of a dissection: which lie on both outer boundaries, and where.

    Attributes
    ----------
    anchors : (a, 2, 2) float64
    on_both : (a,) bool
        Anchors on both outer boundaries.
    proj : dict of int to list of (float, (2,) float64, float)
        Per boundary anchor, its projection on the source and the target outer
        ring (arc-length parameter, point, distance).
    order : list of int
        Boundary anchors in cyclic order along the source ring.
    pos : dict of int to int
        Position of each boundary anchor in ``order``.
    """

    anchors: FloatArray
    on_both: BoolArray
    proj: dict[int, list[tuple[float, FloatArray, float]]]
    order: list[int]
    pos: dict[int, int]

    def point(self, x: int, side: int) -> FloatArray:
        """Anchor x in shape ``side`` (0 source, 1 target), projected if on the boundary."""
        return self.proj[x][side][1] if x in self.proj else self.anchors[x, side]


def dissection_anchors(
    source: ShapeRings, target: ShapeRings, anchors: FloatArray
) -> DissectionAnchors:
    """The boundary anchors of both shapes, projected on the outer rings and in order.

    Parameters
    ----------
    source, target : ShapeRings
    anchors : (a, 2, 2) float64

    Returns
    -------
    DissectionAnchors

    Raises
    ------
    ShapeError
        Boundary anchors in different orders along the two outer rings.
    """
    shapes = (source, target)
    diag = [float(np.linalg.norm(np.ptp(sh.outer, axis=0))) for sh in shapes]
    on = [
        distance_to_rings(ShapeRings(sh.outer, (), ()), anchors[:, k])
        <= ANCHOR_ON_BOUNDARY_RTOL * d
        for k, (sh, d) in enumerate(zip(shapes, diag, strict=True))
    ]
    bidx = np.flatnonzero(on[0] & on[1])
    proj = {
        int(i): [_project_on_ring(sh.outer, anchors[i, k]) for k, sh in enumerate(shapes)]
        for i in bidx
    }
    order = sorted(proj, key=lambda i: proj[i][0][0])  # cyclic order along the source ring
    t_par = np.array([proj[i][1][0] for i in order])
    rot = int(np.argmin(t_par))
    if np.any(np.diff(np.roll(t_par, -rot)) <= 0):
        raise ShapeError("boundary anchors are in different orders along the two outer boundaries")
    pos = {i: k for k, i in enumerate(order)}
    return DissectionAnchors(anchors, on[0] & on[1], proj, order, pos)


def checked_paths(
    shapes: tuple[ShapeRings, ShapeRings], da: DissectionAnchors, paths: Sequence[Sequence[int]]
) -> tuple[list[list[int]], set[int]]:
    """The paths as lists of anchor indices, each checked, and the interior anchors they use.

    Parameters
    ----------
    shapes : (ShapeRings, ShapeRings)
        Source and target.
    da : DissectionAnchors
    paths : sequence of sequences of int

    Returns
    -------
    cuts : list of list of int
    used : set of int
        Interior anchors on a path.

    Raises
    ------
    PathError
        Too short, an index out of range, ends not on both boundaries, an
        interior anchor on the boundary or on two paths, an anchor visited twice,
        a piece leaving a shape, two paths crossing or the same.
    """
    a = da.anchors.shape[0]
    pos, point = da.pos, da.point
    used: set[int] = set()
    cuts: list[list[int]] = []
    for k, path in enumerate(paths):
        path = [int(x) for x in path]
        if len(path) < 2:
            raise PathError(f"path {k} must list at least two anchor indices, got {path}", k)
        for x in path:
            if not 0 <= x < a:
                raise PathError(f"path {k} names anchor {x}; there are {a} anchors", k)
        for x in (path[0], path[-1]):
            if x not in pos:
                raise PathError(
                    f"path {k} must start and end on both outer boundaries; anchor {x} does not", k
                )
        for x in path[1:-1]:
            if x in pos:
                raise PathError(f"path {k}: anchor {x} inside the path lies on the boundary", k)
            if x in used:
                raise PathError(f"path {k}: interior anchor {x} is on another path", k)
            used.add(x)
        if path[0] == path[-1] or len(set(path)) != len(path):
            raise PathError(f"path {k} {path} visits an anchor twice", k)
        for side, sh in enumerate(shapes):
            for u, w in itertools.pairwise(path):
                if not _chord_inside(sh, point(u, side), point(w, side)):
                    raise PathError(
                        f"path {k} leaves the {'source' if side == 0 else 'target'} shape between "
                        f"anchors {u} and {w}",
                        k,
                    )
        cuts.append(path)
    for k1, k2 in itertools.combinations(range(len(cuts)), 2):
        c1, c2 = cuts[k1], cuts[k2]
        ends1, ends2 = (c1[0], c1[-1]), (c2[0], c2[-1])
        if len(set(ends1) | set(ends2)) == 4:
            lo, hi = sorted((pos[ends1[0]], pos[ends1[1]]))
            if (lo < pos[ends2[0]] < hi) != (lo < pos[ends2[1]] < hi):
                raise PathError(f"paths {k1} and {k2} cross", k2)
        if set(ends1) == set(ends2) and len(c1) == len(c2) == 2:
            raise PathError(f"paths {k1} and {k2} are the same cut", k2)
        for side in (0, 1):
            for u1, w1 in itertools.pairwise(c1):
                for u2, w2 in itertools.pairwise(c2):
                    if _segments_meet(
                        point(u1, side), point(w1, side), point(u2, side), point(w2, side)
                    ):
                        raise PathError(f"paths {k1} and {k2} cross", k2)
    return cuts, used


def cut_polygons(order: list[int], cuts: list[list[int]]) -> list[list[PolygonEdge]]:
    """The patch polygons that the cuts make of the disk bounded by the anchors ``order``.

    Each cut splits the polygon holding both its ends in two.

    Parameters
    ----------
    order : list of int
        Boundary anchors in ring order.
    cuts : list of list of int
        Checked paths.

    Returns
    -------
    list of list of PolygonEdge
        ``len(cuts) + 1`` polygons, each a cycle of (corner, edge to the next).

    Examples
    --------
    >>> cut_polygons([0, 1, 2, 3], [[0, 2]])
    [[(0, None), (1, None), (2, (2, 0))], [(2, None), (3, None), (0, (0, 2))]]
    """
    polygons: list[list[PolygonEdge]] = [[(x, None) for x in order]]
    for path in cuts:
        i, j = path[0], path[-1]
        for pi, poly in enumerate(polygons):
            corners = [c for c, _ in poly]
            if i in corners and j in corners:
                ii, jj = corners.index(i), corners.index(j)
                fwd = tuple(path)
                if ii > jj:
                    ii, jj, fwd = jj, ii, fwd[::-1]
                # poly[ii] … poly[jj], closed by the cut jj → ii; the rest, closed by ii → jj
                left = poly[ii:jj] + [(poly[jj][0], fwd[::-1])]
                right = poly[jj:] + poly[:ii] + [(poly[ii][0], fwd)]
                polygons[pi : pi + 1] = [left, right]
                break
    return polygons
