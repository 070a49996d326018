"""Compatible (isomorphic) triangulations of two planar shapes ("From Objects to Isomorphic Meshes").

Follows the second half of Yan, Hu and Martin (2004):

1. **Dissection into a disk patch.** Anchors on the outer boundary split both
   rings into corresponding arcs. A shape with holes is cut open along one
   straight cut per hole, from a hole vertex to an outer vertex (the shortest
   inside the shape whose outer ends fall between the same two anchors in
   both shapes; holes are paired by their positions in the bounding boxes).
   The disk's boundary runs along the outer arcs, down each cut, round the
   hole and back. Shapes with different numbers of holes raise
   :class:`~conformorph.geometry.shape_rings.HoleCorrespondenceError`.
2. **Consistent boundaries.** On each arc the vertices of *both* shapes are
   kept (their normalised arc-length positions are merged, and a source and a
   target vertex closer than a quarter of the local spacing are paired
   instead of both being inserted), so no corner of either shape is lost;
   long pieces are split equally in both.
3. **Patch triangulation.** Each shape is triangulated (constrained Delaunay,
   no Steiner points on the boundary or the cuts, quality refinement inside)
   and cut open into the disk.
4. **Mean-value parameterisation** (Floater 2003) of each disk onto the same
   convex polygon inscribed in the unit circle (corners at the mean of the
   two shapes' normalised arc lengths), a bijection by Floater's theorem.
5. **Merge** the interior points of both parameterisations (points closer
   than a threshold are merged), triangulate the merged set in the polygon
   (constrained Delaunay) and **map back** through each parameterisation.
6. **Remove flips.** Edge flips valid in both meshes first (the paper's
   step); every triangle still flipped is *refined*: the edges of that
   shape's parameterisation meeting it become constraint segments and the
   merged set is re-triangulated (Triangle inserts the crossings). The map
   back is a piecewise-linear homeomorphism, linear on each triangle of the
   overlay of the two parameterisations, so this ends with no flips at the
   latest when the refined region reaches the overlay; in practice after a
   few rounds and with several times fewer triangles than the overlay
   (``overlay_triangles`` reports the overlay's size).
7. **Glue** the cut shut, then a fallback repair (edge flips, kernel-centre
   relocation) for anything left (only interior anchors, whose positions are
   imposed, can leave some), and **quality** improvement (edge flips raising
   the worse minimum angle, interior vertices relaxed where that stays valid).

The steps live in their own modules: boundary anchors
(:mod:`conformorph.geometry.boundary_anchors`), hole cuts (:mod:`conformorph.geometry.hole_cuts`),
consistent boundaries (:mod:`conformorph.geometry.consistent_boundaries`), the disk
patches and their mean-value maps (:mod:`conformorph.geometry.mean_value_patches`), the
merged triangulation and its refinement (:mod:`conformorph.geometry.merged_triangulation`,
with :mod:`conformorph.geometry.parameter_overlay`), the flip repair
(:mod:`conformorph.geometry.flip_repair`) and the quality improvement
(:mod:`conformorph.geometry.compatible_mesh_quality`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .boundary_anchors import ANCHOR_ON_BOUNDARY_RTOL, boundary_anchors
from .compatible_mesh_quality import collapse_slivers, improve_quality, min_triangle_angle
from .consistent_boundaries import consistent_boundaries
from .flip_repair import _areas, repair_flips
from .hole_cuts import check_hole_counts, hole_cuts
from .mean_value_patches import glue_cut, patch_maps
from .merged_triangulation import MergedPoints, refined_merged_triangulation
from .parameter_overlay import overlay_triangle_count  # noqa: F401 - re-exported
from .shape_rings import ShapeRings

__all__ = [
    "ANCHOR_ON_BOUNDARY_RTOL",
    "CompatibleTriangulation",
    "compatible_triangulation",
    "min_triangle_angle",
    "overlay_triangle_count",
]


@dataclass(frozen=True)
class CompatibleTriangulation:
    """Two meshes with the same triangles.

    Attributes
    ----------
    source_V, target_V : (n, 2) float64
        Vertex positions in the source and the target shape.
    F : (m, 3) int64
        Triangles, counter-clockwise in both when ``flipped == (0, 0)``.
    anchor_vertices : (a,) int64
        The vertex at each anchor pair (in the input order).
    boundary_vertices : int
        Vertices 0 … boundary_vertices−1 form the common outer boundary.
    flipped : tuple of int
        Triangles with non-positive area in the source and the target mesh.
    min_angle : tuple of float
        Smallest triangle angle in degrees in each mesh.
    merged_points : int
        Interior points of the two parameterisations that were merged.
    repair_rounds : int
        Rounds of the fallback flip repair used.
    hole_vertices : int
        Vertices boundary_vertices … boundary_vertices+hole_vertices−1 lie on
        the holes' rings (each hole in its ring order).
    refinement_points : int
        Points added to the merged set by the adaptive refinement.
    refinement_rounds : int
        Re-triangulations the refinement needed.
    overlay_triangles : int
        Triangles an overlay of the two parameterisations would have
        (:func:`overlay_triangle_count`), for comparison with ``n_triangles``.
    budget_collapses : int
        Free vertices removed afterwards to meet a vertex budget
        (:func:`conformorph.geometry.vertex_budget_collapse.budgeted_triangulation`).
    """

    source_V: FloatArray
    target_V: FloatArray
    F: IntArray
    anchor_vertices: IntArray
    boundary_vertices: int
    flipped: tuple[int, int]
    min_angle: tuple[float, float]
    merged_points: int
    repair_rounds: int
    hole_vertices: int = 0
    refinement_points: int = 0
    refinement_rounds: int = 0
    overlay_triangles: int = -1
    budget_collapses: int = 0

    @property
    def n_triangles(self) -> int:
        """Number of triangles."""
        return int(self.F.shape[0])


def compatible_triangulation(
    source: ShapeRings,
    target: ShapeRings,
    anchors: FloatArray,
    *,
    triangles_per_shape: int = 200,
    min_angle: float = 25.0,
    repair_rounds: int = 16,
    smoothing_rounds: int = 3,
    max_refinements: int = 60,
    simplify: bool = True,
    hole_match: Sequence[int] | None = None,
) -> CompatibleTriangulation:
    """Build two meshes with identical connectivity covering two planar shapes.

    Parameters
    ----------
    source, target : ShapeRings
        Validated shapes with equally many holes.
    anchors : (a, 2, 2) float64
        Corresponding points ``anchors[i] = [[x_s, y_s], [x_t, y_t]]``; at
        least one must lie on both outer boundaries (within
        ``ANCHOR_ON_BOUNDARY_RTOL`` of the diagonal); the others may be inside.
    triangles_per_shape : int, optional
        Each shape is refined to triangles of area at most its area divided by
        this before parameterisation (fewer triangles, faster morphs).
    min_angle : float, optional
        Quality bound (degrees) of those triangulations.
    repair_rounds : int, optional
        Rounds of the fallback flip repair (edge flips, then kernel
        relocation), used only for what refinement leaves (interior anchors).
    smoothing_rounds : int, optional
        Rounds of quality improvement (edge flips, interior-vertex relaxation)
        that keep every triangle positive.
    max_refinements : int, optional
        Rounds of adaptive refinement of the merged triangulation.
    simplify : bool, optional
        Collapse free vertices where that raises the local minimum angle in
        both meshes (removes the slivers refinement leaves at crossings).
    hole_match : sequence of int, optional
        Target hole of each source hole (e.g. ``range(k)`` after
        :func:`geometry.seed_missing_holes`, which pairs holes through the
        anchors); default: the pairing nearest in bounding-box coordinates.

    Returns
    -------
    CompatibleTriangulation
        ``flipped`` reports any triangle left flipped (none for boundary
        anchors only: refinement goes on until none is, step 6 of the module docstring).

    Raises
    ------
    HoleCorrespondenceError
        If the shapes have different numbers of holes, or a pair of holes
        cannot be cut to the outer boundary between the same two anchors.
    TooFewAnchorsError
        If no anchor lies on both outer boundaries.
    AnchorOutsideShapeError
        If an anchor lies outside its shape.
    ShapeError
        If boundary anchors are in a different cyclic order on the two
        boundaries, or an anchor is on one boundary but inside the other shape.

    References
    ----------
    H.-B. Yan, S.-M. Hu, R. R. Martin, "Morphing based on strain field
    interpolation", Computer Animation and Virtual Worlds 15 (2004) 443–452,
    doi:10.1002/cav.48. M. S. Floater, "Mean value coordinates", CAGD 20
    (2003) 19–27, doi:10.1016/S0167-8396(03)00002-5.
    """
    check_hole_counts(source, target)
    anchors = np.asarray(anchors, dtype=np.float64)
    ba = boundary_anchors(source, target, anchors)
    inner = ba.inner
    n_in = inner.size
    # 1. dissection into one disk patch: a straight cut from each hole to the outer ring
    cuts = hole_cuts(source, target, ba.s_par, ba.t_par, hole_match)
    # 2. consistent boundaries
    spacing = tuple(np.sqrt(2.0 * s.area / triangles_per_shape) for s in (source, target))
    boundary = consistent_boundaries(source, target, cuts, (spacing[0], spacing[1]))
    nb, n_u = boundary.nb, boundary.n_u
    # 3-4. patch triangulations, cut open into disks, and their mean-value maps
    maps = patch_maps(
        source, target, boundary, cuts.hole_match, anchors[inner], (triangles_per_shape, min_angle)
    )
    # 5. merge the inner points of both parameterisations, triangulate, map back;
    # 6. refine where a triangle flips (the overlay built only there)
    points = MergedPoints(maps, n_in)
    UV, F, Xd, refinements = refined_merged_triangulation(
        maps, points, anchors[inner], max_refinements
    )
    added = UV.shape[0] - nb - points.initial
    # 7. glue the cut, repair what is left, improve the quality
    Xs, Xt, F, fixed = glue_cut(boundary, F, Xd, n_in)
    Xs, Xt, F, rounds = repair_flips(Xs, Xt, F, fixed, repair_rounds)
    ids = np.arange(Xs.shape[0])
    if simplify and not (np.any(_areas(Xs, F) <= 0) or np.any(_areas(Xt, F) <= 0)):
        Xs, Xt, F, fixed, ids, _ = collapse_slivers(Xs, Xt, F, fixed)
    F = improve_quality(Xs, Xt, F, fixed, smoothing_rounds)

    anchor_vertices = np.zeros(anchors.shape[0], dtype=np.int64)
    anchor_vertices[ba.bidx] = boundary.uid[boundary.anchor_pos]
    anchor_vertices[inner] = np.searchsorted(ids, n_u + np.arange(n_in))
    return CompatibleTriangulation(
        Xs,
        Xt,
        F,
        anchor_vertices,
        boundary_vertices=boundary.n_outer,
        flipped=(int(np.sum(_areas(Xs, F) <= 0)), int(np.sum(_areas(Xt, F) <= 0))),
        min_angle=(min_triangle_angle(Xs, F), min_triangle_angle(Xt, F)),
        merged_points=points.merged,
        repair_rounds=rounds,
        hole_vertices=boundary.n_hole,
        refinement_points=added,
        refinement_rounds=refinements,
        overlay_triangles=maps.overlay_triangles,
    )
