"""Dissection of two shapes into corresponding patches along paths between boundary anchors.

Yan, Hu and Martin (2004, "From Objects to Isomorphic Meshes") cut both
shapes into corresponding patches along paths between feature points and
parameterise each patch on its own. A single disk patch
(:func:`conformorph.geometry.compatible_triangulation.compatible_triangulation` without
paths) crowds a long protrusion (a horse's leg) into a thin sliver next to
its boundary in the mean-value parameterisation, which is exponentially
small in the protrusion's length-to-width ratio; where the other shape has
no protrusion there, the compatible mesh inherits that sliver (on horse →
star: the largest / smallest principal stretch of one triangle ~560). A path
across the protrusion's base makes it a patch of its own.

Choices where the paper is silent
---------------------------------
* **Paths are polylines through anchors**, given by the caller as lists of
  anchor indices: from a boundary anchor, through interior anchors, to a
  boundary anchor, straight between consecutive ones, in both shapes. Each
  must lie inside both shapes, and no two may cross. An interior anchor lets
  a path turn, e.g. round a reflex corner of the other shape, where no
  straight cut between two boundary points stays inside. Shapes with holes
  are not dissected (their one cut per hole already makes a disk).
* **Consistent path points.** Each piece of a path is split into equally
  many equal parts in both shapes, short enough that neither adjacent
  patch's triangulation splits it again (0.9 of the smaller of their target
  edge lengths), and computed from the same end whichever way a patch walks
  it, so both patches meet at bit-identical points and glue without a seam.
* **Anchors at both sides of a protrusion's end.** Not a choice of this
  module but what makes it work: each patch is parameterised onto a convex
  polygon whose corners are its anchors, so a leg whose two long sides run
  between different corners maps to a quadrilateral-like polygon with
  distortion of the order of its length-to-width ratio, not exponential in it.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ._typing import FloatArray, IntArray
from .boundary_anchors import _ring_arc
from .compatible_mesh_quality import min_triangle_angle
from .compatible_triangulation import CompatibleTriangulation, compatible_triangulation
from .conformal_relaxation import conformal_relaxation
from .dissection_paths import PolygonEdge, checked_paths, cut_polygons, dissection_anchors
from .flip_repair import _areas
from .shape_rings import (
    ShapeError,
    ShapeRings,
    points_in_shape,
    ring_signed_area,
)

#: Newton steps of the glued target's symmetric Dirichlet relaxation (horse → star
#: stopped converged after 50).
RELAX_MAX_ITERATIONS = 100

#: A boundary vertex of the glued target slides along the straight side it lies
#: on (:func:`straight_side_vertices`) when its distance to the line through its
#: neighbours is at most this fraction of their distance (points put on a side
#: by interpolation are on it to round-off, ~1e-16).
STRAIGHT_SIDE_RTOL = 1e-9

#: Relative tolerance (of the shape's bounding-box diagonal) within which
#: vertices of two patches are the same vertex of the glued mesh.
GLUE_RTOL = 1e-9


@dataclass(frozen=True)
class Patch:
    """One patch in both shapes.

    Attributes
    ----------
    source_ring, target_ring : (k, 2) float64
        Counter-clockwise rings (first point not repeated); corner ``j`` of
        both is ``corners[j]``.
    anchors : (c, 2, 2) float64
        The patch's anchor pairs: its corners (boundary anchors of the
        shapes) first, then the interior anchors inside it.
    anchor_index : (c,) int64
        Each of those pairs' index in the caller's anchor list.
    """

    source_ring: FloatArray
    target_ring: FloatArray
    anchors: FloatArray
    anchor_index: IntArray


def dissect_shapes(
    source: ShapeRings,
    target: ShapeRings,
    anchors: FloatArray,
    paths: Sequence[Sequence[int]],
    *,
    triangles_per_shape: int = 200,
) -> list[Patch]:
    """Cut both shapes along paths between boundary anchors into corresponding patches.

    Parameters
    ----------
    source, target : ShapeRings
        Validated shapes without holes.
    anchors : (a, 2, 2) float64
    paths : sequence of sequences of int
        Anchor indices ``[i, m1, …, j]``: a cut from boundary anchor i through
        the interior anchors m1, … (straight between consecutive ones) to
        boundary anchor j, in both shapes. An interior anchor belongs to at
        most one path.
    triangles_per_shape : int, optional
        As in :func:`compatible_triangulation`, per patch: sets how finely
        paths are split.

    Returns
    -------
    list of Patch
        ``len(paths) + 1`` patches; each path's interior anchors are corners
        of the two patches beside it.

    Raises
    ------
    PathError
        A path with fewer than two anchors or an index out of range; ends
        not on both outer boundaries or inner anchors not inside both; an
        anchor used twice; a piece leaving a shape; two paths crossing.
    ShapeError
        Shapes with holes, or boundary anchors in different orders.
    """
    if source.holes or target.holes:
        raise ShapeError("paths cannot dissect shapes with holes (their cuts already make a disk)")
    anchors = np.asarray(anchors, dtype=np.float64)
    shapes = (source, target)
    da = dissection_anchors(source, target, anchors)
    proj, point = da.proj, da.point
    cuts, used = checked_paths(shapes, da, paths)
    polygons = cut_polygons(da.order, cuts)

    def pieces_of(path: tuple[int, ...], m: dict[tuple[int, int], int], side: int) -> FloatArray:
        """The cut's points from its first anchor up to (not including) its last."""
        parts = []
        for u, w in itertools.pairwise(path):
            lo, hi = min(u, w), max(u, w)
            n_seg = m.get((lo, hi), 1)
            # computed from the lower index whichever way the cut is walked: the two
            # patches beside it get bit-identical points
            s_ = np.arange(n_seg + 1)[:, None] / n_seg
            pts = point(lo, side)[None] + s_ * (point(hi, side) - point(lo, side))[None]
            parts.append(pts[:-1] if u == lo else pts[:0:-1])
        return np.vstack(parts)

    def ring_of(poly: list[PolygonEdge], side: int, m: dict[tuple[int, int], int]) -> FloatArray:
        parts = []
        for k, (u, cut) in enumerate(poly):
            w = poly[(k + 1) % len(poly)][0]
            if cut is None:
                parts.append(_ring_arc(shapes[side].outer, proj[u][side][0], proj[w][side][0])[:-1])
            else:
                parts.append(pieces_of(cut, m, side))
        return np.vstack(parts)

    rough = [[ring_of(p, side, {}) for side in (0, 1)] for p in polygons]
    h = np.array(
        [
            [np.sqrt(2.0 * abs(ring_signed_area(r)) / triangles_per_shape) for r in pair]
            for pair in rough
        ]
    )  # (patches, 2): each patch's target edge length
    m: dict[tuple[int, int], int] = {}
    for path in cuts:
        near = [
            k
            for k, poly in enumerate(polygons)
            if any(c is not None and set(c) == set(path) for _, c in poly)
        ]
        for u, w in itertools.pairwise(path):
            n_seg = 1
            for side in (0, 1):
                length = float(np.linalg.norm(point(w, side) - point(u, side)))
                n_seg = max(n_seg, int(np.ceil(length / (0.9 * h[near, side].min()))))
            m[(min(u, w), max(u, w))] = n_seg

    inner = [int(x) for x in np.flatnonzero(~da.on_both) if int(x) not in used]
    patches = []
    for poly in polygons:
        rings = [ring_of(poly, side, m) for side in (0, 1)]
        corners = [c for c, _ in poly]
        corners += [x for _, cut in poly if cut is not None for x in cut[1:-1]]
        ins = [
            x
            for x in inner
            if points_in_shape(ShapeRings(rings[0], (), ()), anchors[x : x + 1, 0])[0]
        ]
        idx = np.array(corners + ins, dtype=np.int64)
        pa = np.array([[point(int(x), 0), point(int(x), 1)] for x in idx])
        patches.append(Patch(rings[0], rings[1], pa, idx))
    return patches


def dissected_triangulation(
    source: ShapeRings,
    target: ShapeRings,
    anchors: FloatArray,
    paths: Sequence[Sequence[int]],
    *,
    triangles_per_shape: int = 200,
    relax: bool = True,
    **options: object,
) -> CompatibleTriangulation:
    """Compatible triangulation glued from the compatible triangulations of corresponding patches.

    Parameters
    ----------
    source, target : ShapeRings
        Validated shapes without holes.
    anchors : (a, 2, 2) float64
    paths : sequence of sequences of int
        See :func:`dissect_shapes`.
    triangles_per_shape : int, optional
        Passed to each patch's :func:`compatible_triangulation`.
    relax : bool, optional
        Relax the glued target mesh's free vertices (interior, not anchors) on
        the symmetric Dirichlet energy of the map from the source
        (:func:`_relax_target`).
    **options
        Further keyword options of :func:`compatible_triangulation`.

    Returns
    -------
    CompatibleTriangulation
        Its outer boundary first (vertices ``0 … boundary_vertices − 1`` in
        ring order from the first boundary anchor); ``merged_points``,
        ``refinement_points``, ``refinement_rounds``, ``repair_rounds`` and
        ``overlay_triangles`` summed over the patches.

    Raises
    ------
    PathError, ShapeError
        As :func:`dissect_shapes` and :func:`compatible_triangulation`.
    """
    patches = dissect_shapes(
        source, target, anchors, paths, triangles_per_shape=triangles_per_shape
    )
    diag_s = float(np.linalg.norm(np.ptp(source.outer, axis=0)))
    diag_t = float(np.linalg.norm(np.ptp(target.outer, axis=0)))
    Xs_l: list[FloatArray] = []
    Xt_l: list[FloatArray] = []
    F_l: list[IntArray] = []
    totals = dict(merged=0, repair=0, refine_pts=0, refine_rounds=0, overlay=0)
    offset = 0
    anchor_vertex = np.full(np.asarray(anchors).shape[0], -1, dtype=np.int64)
    for patch in patches:
        ps = ShapeRings(patch.source_ring, (), ())
        pt = ShapeRings(patch.target_ring, (), ())
        ct = compatible_triangulation(
            ps,
            pt,
            patch.anchors,
            triangles_per_shape=triangles_per_shape,
            **options,  # type: ignore[arg-type]
        )
        Xs_l.append(ct.source_V)
        Xt_l.append(ct.target_V)
        F_l.append(ct.F + offset)
        anchor_vertex[patch.anchor_index] = ct.anchor_vertices + offset
        offset += ct.source_V.shape[0]
        totals["merged"] += ct.merged_points
        totals["repair"] += ct.repair_rounds
        totals["refine_pts"] += ct.refinement_points
        totals["refine_rounds"] += ct.refinement_rounds
        totals["overlay"] += max(ct.overlay_triangles, 0)
    if np.any(anchor_vertex < 0):
        i = int(np.flatnonzero(anchor_vertex < 0)[0])
        raise ShapeError(f"anchor {i} lies in no patch (on a path it is not part of?)")
    Xs, Xt, F = np.vstack(Xs_l), np.vstack(Xt_l), np.vstack(F_l)
    Xs, Xt, F, anchor_vertex = glue_patches(Xs, Xt, F, anchor_vertex, (diag_s, diag_t))
    Xs, Xt, F, anchor_vertex, n_loop = outer_boundary_first(Xs, Xt, F, anchor_vertex)
    if relax and np.all(_areas(Xs, F) > 0) and np.all(_areas(Xt, F) > 0):
        Xt = _relax_target(Xs, Xt, F, n_loop, anchor_vertex)
    return CompatibleTriangulation(
        source_V=Xs,
        target_V=Xt,
        F=F,
        anchor_vertices=anchor_vertex,
        boundary_vertices=n_loop,
        flipped=(int(np.sum(_areas(Xs, F) <= 0)), int(np.sum(_areas(Xt, F) <= 0))),
        min_angle=(min_triangle_angle(Xs, F), min_triangle_angle(Xt, F)),
        merged_points=totals["merged"],
        repair_rounds=totals["repair"],
        refinement_points=totals["refine_pts"],
        refinement_rounds=totals["refine_rounds"],
        overlay_triangles=totals["overlay"],
    )


def glue_patches(
    Xs: FloatArray,
    Xt: FloatArray,
    F: IntArray,
    anchor_vertex: IntArray,
    diagonals: tuple[float, float],
) -> tuple[FloatArray, FloatArray, IntArray, IntArray]:
    """Glue the patches' meshes: vertices at the same source point (within GLUE_RTOL) are one.

    Parameters
    ----------
    Xs, Xt : (n, 2) float64
        The patches' vertices, stacked.
    F : (m, 3) int64
    anchor_vertex : (a,) int64
    diagonals : (float, float)
        Bounding-box diagonals of the source and the target shape.

    Returns
    -------
    Xs, Xt : (n', 2) float64
        Each glued vertex at the position of its first copy.
    F : (m, 3) int64
    anchor_vertex : (a,) int64

    Raises
    ------
    ShapeError
        Copies of a vertex that are apart in the target.
    """
    diag_s, diag_t = diagonals
    # glue: vertices at the same source point (within GLUE_RTOL) are one vertex
    pairs = cKDTree(Xs).query_pairs(GLUE_RTOL * diag_s, output_type="ndarray")
    n_all = Xs.shape[0]
    link = sp.coo_array((np.ones(pairs.shape[0]), (pairs[:, 0], pairs[:, 1])), shape=(n_all, n_all))
    _, inverse = connected_components(link, directed=False)
    first = np.zeros(inverse.max() + 1, dtype=np.int64)
    first[inverse[::-1]] = np.arange(n_all)[::-1]
    gap = float(np.abs(Xt - Xt[first[inverse]]).max(initial=0.0))
    if gap > GLUE_RTOL * diag_t:
        raise ShapeError(
            f"patches do not meet at the same target points along a path ({gap:.3g} apart)"
        )
    F = inverse[F]
    Xs, Xt = Xs[first], Xt[first]
    anchor_vertex = inverse[anchor_vertex]
    return Xs, Xt, F, anchor_vertex


def outer_boundary_first(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, anchor_vertex: IntArray
) -> tuple[FloatArray, FloatArray, IntArray, IntArray, int]:
    """Renumber the vertices: the outer boundary first, in ring order from the first anchor on it.

    Parameters
    ----------
    Xs, Xt : (n, 2) float64
    F : (m, 3) int64
        A manifold disk mesh.
    anchor_vertex : (a,) int64

    Returns
    -------
    Xs, Xt : (n, 2) float64
    F : (m, 3) int64
    anchor_vertex : (a,) int64
    boundary_vertices : int
        Length of the boundary loop.

    Raises
    ------
    ShapeError
        A non-manifold mesh, or a boundary that is not one loop.
    """
    n = Xs.shape[0]
    e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    if np.any(c > 2):
        raise ShapeError("the glued patches are not a manifold mesh")
    directed = np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    bset = {tuple(x) for x in u[c == 1]}
    nxt = {int(p): int(q) for p, q in directed if (min(p, q), max(p, q)) in bset}
    start = int(anchor_vertex[np.flatnonzero(anchor_vertex >= 0)[0]])
    start = start if start in nxt else next(iter(nxt))
    loop = [start]
    while nxt[loop[-1]] != start:
        loop.append(nxt[loop[-1]])
        if len(loop) > n:
            raise ShapeError("the glued patches' boundary is not one loop")
    rest = np.setdiff1d(np.arange(n), loop)
    perm = np.concatenate([np.array(loop), rest])
    newid = np.zeros(n, dtype=np.int64)
    newid[perm] = np.arange(n)
    Xs, Xt, F = Xs[perm], Xt[perm], newid[F]
    anchor_vertex = newid[anchor_vertex]
    return Xs, Xt, F, anchor_vertex, len(loop)


def _relax_target(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, n_boundary: int, anchor_vertices: IntArray
) -> FloatArray:
    """The target mesh with its free vertices moved to lower the map's symmetric Dirichlet energy.

    Each patch's map is a composition of two mean-value parameterisations,
    which squeezes a protrusion that has no counterpart in the other shape
    (a horse's fourth leg against a star's tips) into a sliver along the
    boundary. The symmetric Dirichlet energy ``|J|² + |J⁻¹|²`` of the map
    source → target (source scaled to the target's area, so that the
    optimum keeps area on average) is infinite as a triangle collapses in any
    direction: Newton on it (:func:`conformorph.geometry.conformal_relaxation`, never
    leaving the injective maps) moves the interior vertices off the boundary.
    Every anchor stays where it is; a boundary vertex on a straight side of
    the target (:func:`straight_side_vertices`) slides along that side, the
    others stay. Measured on horse → star with four paths (without sliding):
    smallest principal stretch 0.0065 → 0.08, triangles with anisotropy over
    30: 646 → 277. Sliding, on horse → star with 13 boundary anchors and 4 paths
    through 4 interior anchors (2534 vertices): largest anisotropy 337 → 256,
    triangles over 100: 98 → 47.
    """
    n = Xs.shape[0]
    free = np.ones(n, dtype=bool)
    free[:n_boundary] = False
    free[anchor_vertices] = False
    slide, directions = straight_side_vertices(Xt[:n_boundary], exclude=anchor_vertices)
    area_s = float(_areas(Xs, F).sum())
    area_t = float(_areas(Xt, F).sum())
    relaxed, _ = conformal_relaxation(
        Xs * np.sqrt(area_t / area_s),
        F,
        Xt,
        np.flatnonzero(free),
        max_iterations=RELAX_MAX_ITERATIONS,
        energy="symmetric_dirichlet",
        slide=slide,
        slide_directions=directions,
    )
    return relaxed


def straight_side_vertices(
    ring: FloatArray, *, exclude: IntArray | None = None, rtol: float = STRAIGHT_SIDE_RTOL
) -> tuple[IntArray, FloatArray]:
    """The vertices of a closed polygon that lie on a straight side between their two
    neighbours, and that side's direction.

    Parameters
    ----------
    ring : (k, 2) float64
        The polygon's vertices in order (first not repeated), k ≥ 3.
    exclude : (e,) int64, optional
        Vertices never returned (anchors).
    rtol : float, optional
        Vertex i counts as on the side when its distance to the line through
        its neighbours is at most ``rtol`` times their distance.

    Returns
    -------
    index : (s,) int64
        Ascending.
    direction : (s, 2) float64
        Unit vectors from each one's previous neighbour to its next.

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[0., 0], [1, 0], [2, 0], [2, 2], [0, 2], [0, 1]])
    >>> i, d = straight_side_vertices(sq)
    >>> i.tolist(), d.tolist()
    ([1, 5], [[1.0, 0.0], [0.0, -1.0]])
    """
    ring = np.asarray(ring, dtype=np.float64)
    if ring.ndim != 2 or ring.shape[1] != 2 or ring.shape[0] < 3:
        raise ValueError(f"ring must have shape (k, 2) with k >= 3, got {ring.shape}")
    prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    chord = nxt - prev
    length = np.linalg.norm(chord, axis=1)
    off = ring - prev
    cross = np.abs(chord[:, 0] * off[:, 1] - chord[:, 1] * off[:, 0])
    # between its neighbours, not beyond them
    along = np.einsum("kd,kd->k", off, chord)
    on = (length > 0) & (cross <= rtol * length**2) & (along > 0) & (along < length**2)
    if exclude is not None:
        ex = np.asarray(exclude, dtype=np.int64)
        on[ex[(ex >= 0) & (ex < ring.shape[0])]] = False
    index = np.flatnonzero(on)
    return index, chord[index] / length[index, None]
