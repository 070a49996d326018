"""A vertex budget for two meshes with the same triangles: edge collapses that keep both valid.

The merged triangulation's refinement (:mod:`conformorph.geometry.merged_triangulation`) adds
points until nothing flips, and :func:`conformorph.geometry.compatible_mesh_quality.collapse_slivers`
removes only the vertices whose removal *raises* the local minimum angle. What is left can
still hold many more vertices than the morph needs (issue 18: 644–784 on the horse and
letter pairs). :func:`collapse_to_vertex_budget` removes free vertices, best resulting
quality first, until at most ``max_vertices`` remain or no collapse passes its checks;
:func:`budgeted_triangulation` applies it to a
:class:`~conformorph.geometry.compatible_triangulation.CompatibleTriangulation`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray
from .compatible_mesh_quality import (
    _collapse_choice,
    _collapse_into,
    _face_min_angles,
    improve_quality,
    min_triangle_angle,
)
from .compatible_triangulation import CompatibleTriangulation
from .flip_repair import _areas, _vertex_faces
from .mesh_edges import mesh_boundary_vertices

#: Passes of :func:`collapse_to_vertex_budget` (each collapses an independent set).
BUDGET_COLLAPSE_PASSES = 30
#: Times :func:`collapse_to_vertex_budget` halves its angle bound when the budget is not
#: met (20° → 10° → 5° → 2.5°). B → C (issue 18) needs 5° after the quality smoothing
#: of :func:`conformorph.geometry.compatible_triangulation.compatible_triangulation`; the
#: horse pairs meet 600 at 20°.
BUDGET_ANGLE_HALVINGS = 3


def budgeted_triangulation(
    ct: CompatibleTriangulation,
    max_vertices: int,
    *,
    min_angle: float = 20.0,
    smoothing_rounds: int = 3,
) -> CompatibleTriangulation:
    """A compatible triangulation with at most ``max_vertices`` vertices where collapses allow.

    The boundary vertices (of edges with one triangle) and the anchor vertices
    stay; :func:`collapse_to_vertex_budget` removes free vertices, then
    :func:`conformorph.geometry.compatible_mesh_quality.improve_quality` runs
    again. A triangulation already within the budget, or with a flipped
    triangle, is returned as it is.

    Parameters
    ----------
    ct : CompatibleTriangulation
    max_vertices : int
        ≥ 3.
    min_angle : float, optional
        See :func:`collapse_to_vertex_budget` (degrees, default 20).
    smoothing_rounds : int, optional
        Rounds of quality improvement after the collapses (default 3).

    Returns
    -------
    CompatibleTriangulation
        Vertices renumbered in their old order (``anchor_vertices`` updated),
        ``flipped`` and ``min_angle`` measured again, ``budget_collapses`` set.

    Raises
    ------
    ValueError
        If ``max_vertices`` < 3.
    """
    if max_vertices < 3:
        raise ValueError(f"max_vertices must be at least 3, got {max_vertices}")
    n = ct.source_V.shape[0]
    if n <= max_vertices or ct.flipped != (0, 0):
        return ct
    F = ct.F
    fixed = mesh_boundary_vertices(F, n)
    fixed[ct.anchor_vertices] = True
    Xs, Xt, F, fixed, ids, collapsed = collapse_to_vertex_budget(
        ct.source_V, ct.target_V, F, fixed, max_vertices, min_angle=min_angle
    )
    Xs, Xt = Xs.copy(), Xt.copy()
    F = improve_quality(Xs, Xt, F, fixed, smoothing_rounds)
    return replace(
        ct,
        source_V=Xs,
        target_V=Xt,
        F=F,
        anchor_vertices=np.searchsorted(ids, ct.anchor_vertices).astype(np.int64),
        flipped=(int(np.sum(_areas(Xs, F) <= 0)), int(np.sum(_areas(Xt, F) <= 0))),
        min_angle=(min_triangle_angle(Xs, F), min_triangle_angle(Xt, F)),
        budget_collapses=collapsed,
    )


def collapse_to_vertex_budget(
    Xs: FloatArray,
    Xt: FloatArray,
    F: IntArray,
    fixed: BoolArray,
    max_vertices: int,
    *,
    min_angle: float = 20.0,
) -> tuple[FloatArray, FloatArray, IntArray, BoolArray, IntArray, int]:
    """Collapse free vertices of two unflipped meshes until at most ``max_vertices`` remain.

    Each pass measures, for every free (not ``fixed``) vertex v, its best
    half-edge collapse v → u (the neighbour whose new fan has the largest
    smallest angle over *both* meshes, every new triangle positive in both,
    the link condition holding; the choice of
    :func:`conformorph.geometry.compatible_mesh_quality._collapse_choice`). A
    collapse is allowed when that angle is at least
    ``min(min_angle, smallest angle of v's fan before)``: it never lowers a
    local minimum angle that is below the bound, so the meshes' smallest angle
    never falls below min(bound, what it was). The allowed collapses are done best angle first, skipping
    those whose neighbourhood an earlier collapse of the pass changed, until the
    budget is met. When no collapse is allowed and the budget is not met, the
    bound is halved (at most ``BUDGET_ANGLE_HALVINGS`` times) and the passes go on.

    Parameters
    ----------
    Xs, Xt : (n, 2) float64
        Source and target positions; every triangle positive in both.
    F : (m, 3) int64
        Counter-clockwise triangles.
    fixed : (n,) bool
        Vertices that must stay (boundary, hole rings, anchors).
    max_vertices : int
        Vertex budget (≥ 3). Fewer collapses are done when the checks refuse them.
    min_angle : float, optional
        Degrees; the first bound, see above (default 20).

    Returns
    -------
    Xs, Xt : (n', 2) float64
        The vertices kept, n' ≤ n (unreferenced vertices dropped, fixed ones kept).
    F : (m', 3) int64
        Triangles, renumbered.
    fixed : (n',) bool
    ids : (n',) int64
        Index in the input of each vertex kept.
    collapsed : int
        Vertices removed by collapses.

    Raises
    ------
    ValueError
        If the shapes disagree, ``max_vertices`` < 3, or a triangle is not
        positive in one of the meshes.
    """
    Xs = np.asarray(Xs, dtype=np.float64)
    Xt = np.asarray(Xt, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    fixed = np.asarray(fixed, dtype=bool)
    n = Xs.shape[0]
    if Xs.shape != (n, 2) or Xt.shape != (n, 2) or fixed.shape != (n,):
        raise ValueError(
            f"Xs, Xt must be (n, 2) and fixed (n,); got {Xs.shape}, {Xt.shape}, {fixed.shape}"
        )
    if F.ndim != 2 or F.shape[1] != 3:
        raise ValueError(f"F must be (m, 3), got {F.shape}")
    if max_vertices < 3:
        raise ValueError(f"max_vertices must be at least 3, got {max_vertices}")
    if F.size and (np.any(_areas(Xs, F) <= 0) or np.any(_areas(Xt, F) <= 0)):
        raise ValueError("every triangle must be positive in both meshes")
    collapsed = 0
    choices: dict[int, tuple[float, int, float]] = {}
    for halvings in range(BUDGET_ANGLE_HALVINGS + 1):
        F, done = _budget_collapses(
            Xs, Xt, F, fixed, max_vertices, min_angle * 0.5**halvings, choices
        )
        collapsed += done
    referenced = np.zeros(n, dtype=bool)
    referenced[F.ravel()] = True
    referenced |= fixed
    ids = np.flatnonzero(referenced)
    renum = np.cumsum(referenced) - 1
    return Xs[ids], Xt[ids], renum[F], fixed[ids], ids, collapsed


def _budget_collapses(
    Xs: FloatArray,
    Xt: FloatArray,
    F: IntArray,
    fixed: BoolArray,
    max_vertices: int,
    min_angle: float,
    choices: dict[int, tuple[float, int, float]],
) -> tuple[IntArray, int]:
    """The collapse passes of :func:`collapse_to_vertex_budget`; unreferenced vertices left in place.

    A vertex's choice (:func:`_collapse_choice`) depends only on its bound and on the
    triangles of its neighbours and itself (not on the triangles' numbering): it is
    kept in ``choices`` (vertex → bound, neighbour, angle; updated in place) from pass
    to pass and from bound to bound until a collapse changes that 2-ring, which gives
    the same collapses as measuring every vertex again in every pass.
    """
    n = Xs.shape[0]
    F = F.copy()
    alive = np.ones(F.shape[0], dtype=bool)
    vf = [set(fs) for fs in _vertex_faces(F, n)]
    live = int(sum(1 for v in range(n) if vf[v] or fixed[v]))
    total = 0
    for _ in range(BUDGET_COLLAPSE_PASSES):
        if live <= max_vertices:
            break
        ang = np.minimum(_face_min_angles(Xs, F), _face_min_angles(Xt, F))
        cands: list[tuple[float, int, int]] = []
        for v in range(n):
            if fixed[v] or not vf[v]:
                continue
            faces = sorted(vf[v])
            bound = min(min_angle, float(ang[faces].min())) - 1e-9
            kept = choices.get(v)
            if kept is not None and kept[0] == bound:
                u, a = kept[1], kept[2]
            else:
                u, a = _collapse_choice(Xs, Xt, F, vf, faces, v, bound)
                choices[v] = (bound, u, a)
            if u >= 0:
                cands.append((a, v, u))
        cands.sort(key=lambda c: (-c[0], c[1]))
        touched = np.zeros(n, dtype=bool)
        done = 0
        for _a, v, u in cands:
            if live <= max_vertices:
                break
            if touched[v] or touched[u]:
                continue
            nbrs = _collapse_into(F, vf, alive, v, u)
            touched[v] = True
            touched[list(nbrs)] = True
            for w in {int(x) for y in nbrs for f in vf[y] for x in F[f]} | nbrs | {v}:
                choices.pop(w, None)
            live -= 1
            done += 1
        total += done
        if done == 0:
            break
    return F[alive], total
