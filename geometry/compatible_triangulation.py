"""Compatible (isomorphic) triangulations of two planar shapes ("From Objects to Isomorphic Meshes").

Follows the second half of Yan, Hu and Martin (2004):

1. **Dissection into a disk patch.** Anchors on the outer boundary split both
   rings into corresponding arcs. A shape with holes is cut open along one
   straight cut per hole, from a hole vertex to an outer vertex (the shortest
   inside the shape whose outer ends fall between the same two anchors in
   both shapes; holes are paired by their positions in the bounding boxes).
   The disk's boundary runs along the outer arcs, down each cut, round the
   hole and back. Shapes with different numbers of holes raise
   :class:`~geometry.shape_rings.HoleCorrespondenceError`.
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
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog
from scipy.spatial import cKDTree

from ._typing import BoolArray, FloatArray, IntArray
from .mean_value_weights import mean_value_laplacian
from .point_location import PointLocator
from .shape_rings import (
    AnchorOutsideShapeError,
    HoleCorrespondenceError,
    ShapeError,
    ShapeRings,
    TooFewAnchorsError,
    _segments_cross,
    distance_to_rings,
    points_in_shape,
)
from .sparse_factor import factorize
from .triangulate_shape import point_inside_ring, triangulate_segments

#: An anchor within this fraction of the bounding-box diagonal of the ring
#: counts as lying on the boundary.
ANCHOR_ON_BOUNDARY_RTOL = 1e-3


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

    @property
    def n_triangles(self) -> int:
        """Number of triangles."""
        return int(self.F.shape[0])


def _areas(V: FloatArray, F: IntArray) -> FloatArray:
    e1 = V[F[:, 1]] - V[F[:, 0]]
    e2 = V[F[:, 2]] - V[F[:, 0]]
    return np.asarray(0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]), dtype=np.float64)


def min_triangle_angle(V: FloatArray, F: IntArray) -> float:
    """Smallest corner angle of a triangle mesh, in degrees.

    Parameters
    ----------
    V : (n, 2) float64
    F : (m, 3) int64

    Returns
    -------
    float
    """
    best = 180.0
    for k in range(3):
        a = V[F[:, (k + 1) % 3]] - V[F[:, k]]
        b = V[F[:, (k + 2) % 3]] - V[F[:, k]]
        cos = np.einsum("ij,ij->i", a, b) / np.maximum(
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300
        )
        best = min(best, float(np.degrees(np.arccos(np.clip(cos, -1, 1))).min()))
    return best


def _ring_params(ring: FloatArray) -> tuple[FloatArray, float]:
    seg = np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    return cum, float(cum[-1])


def _project_on_ring(ring: FloatArray, p: FloatArray) -> tuple[float, FloatArray, float]:
    """Arc-length parameter in [0, L), closest point, distance.

    The closest point snaps to an end of its segment when it lies within a
    quarter of the segment *and* within ``ANCHOR_ON_BOUNDARY_RTOL`` of the
    ring's bounding-box diagonal of that end (an anchor meant to sit on a
    vertex, written with a few digits). A point further along a long segment
    keeps its place: a fixed quarter-segment rule moved an anchor placed at a
    tenth of a star's 150-unit edge onto the star's corner, and two such
    anchors onto the same corner.

    Parameters
    ----------
    ring : (k, 2) float64
        Closed ring (first point not repeated).
    p : (2,) float64

    Returns
    -------
    s : float
        Arc-length parameter of the closest point (after snapping).
    q : (2,) float64
        The closest point (after snapping).
    distance : float
        Distance from ``p`` to the ring (before snapping).
    """
    a, b = ring, np.roll(ring, -1, axis=0)
    e = b - a
    ee = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", p[None] - a, e) / ee, 0.0, 1.0)
    q = a + t[:, None] * e
    d = np.linalg.norm(q - p[None], axis=1)
    i = int(np.argmin(d))
    cum, _L = _ring_params(ring)
    ti = float(t[i])
    snap = ANCHOR_ON_BOUNDARY_RTOL * float(np.linalg.norm(np.ptp(ring, axis=0)))
    seg = float(np.sqrt(ee[i]))
    if ti < 0.25 and ti * seg <= snap:
        ti = 0.0
    elif ti > 0.75 and (1.0 - ti) * seg <= snap:
        ti, i = 0.0, (i + 1) % ring.shape[0]
    s = float(cum[i] + ti * np.sqrt(ee[i]) if ti > 0 else cum[i])
    return s, ring[i] + ti * e[i], float(d.min())


def _eval_ring(ring: FloatArray, s: FloatArray) -> FloatArray:
    cum, L = _ring_params(ring)
    s = np.mod(s, L)
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, ring.shape[0] - 1)
    seg = cum[i + 1] - cum[i]
    u = np.where(seg > 0, (s - cum[i]) / np.where(seg > 0, seg, 1.0), 0.0)
    nxt = np.roll(ring, -1, axis=0)
    return np.asarray(ring[i] + u[:, None] * (nxt[i] - ring[i]), dtype=np.float64)


def _mean_value_map(V: FloatArray, F: IntArray, nb: int, circle: FloatArray) -> FloatArray:
    """Floater's mean-value map with vertices 0..nb−1 pinned to ``circle``."""
    W = sp.csr_array(mean_value_laplacian(V, F))
    n = V.shape[0]
    uv = np.zeros((n, 2))
    uv[:nb] = circle
    if n > nb:
        WI = sp.csc_array(W[nb:][:, nb:])
        rhs = -(W[nb:][:, :nb] @ circle)
        uv[nb:] = factorize(WI, symmetric=False).solve(rhs)
    return uv


def _kernel_center(P: FloatArray, A: FloatArray, B: FloatArray) -> FloatArray | None:
    """Chebyshev centre of {x : x left of every directed edge A_i → B_i}, or None if empty."""
    e = B - A
    nrm = np.c_[-e[:, 1], e[:, 0]]
    ln = np.linalg.norm(nrm, axis=1)
    if np.any(ln == 0):
        return None
    # maximise r subject to  n_i·x − |n_i| r ≥ n_i·a_i
    A_ub = np.c_[-nrm, ln]
    b_ub = -np.einsum("ij,ij->i", nrm, A)
    scale = float(np.ptp(np.vstack([A, B]), axis=0).max()) or 1.0
    res = linprog(
        c=[0.0, 0.0, -1.0],
        A_ub=A_ub,
        b_ub=b_ub,
        bounds=[(None, None), (None, None), (0.0, scale)],
        method="highs",
    )
    if res.status != 0 or res.x[2] <= 1e-12 * scale:
        return None
    return np.asarray(res.x[:2], dtype=np.float64)


def _vertex_faces(F: IntArray, n: int) -> list[list[int]]:
    vf: list[list[int]] = [[] for _ in range(n)]
    for f, tri in enumerate(F):
        for v in tri:
            vf[int(v)].append(f)
    return vf


def _one_ring_edges(F: IntArray, faces: list[int], v: int) -> tuple[IntArray, IntArray]:
    """Directed opposite edges (a, b) of v's incident faces, CCW orientation of each face."""
    a, b = [], []
    for f in faces:
        tri = F[f]
        k = int(np.flatnonzero(tri == v)[0])
        a.append(int(tri[(k + 1) % 3]))
        b.append(int(tri[(k + 2) % 3]))
    return np.array(a), np.array(b)


def _relocate(
    V: FloatArray, F: IntArray, vf: list[list[int]], verts: set[int], fixed: FloatArray
) -> FloatArray:
    V = V.copy()
    for v in sorted(verts):
        if fixed[v]:
            continue
        a, b = _one_ring_edges(F, vf[v], v)
        c = _kernel_center(V[v], V[a], V[b])
        if c is not None:
            V[v] = c
    return V


def _edge_flips(Vs: FloatArray, Vt: FloatArray, F: IntArray, bad: IntArray) -> tuple[IntArray, int]:
    """Flip interior edges of bad triangles when both new triangles are positive in both meshes."""
    F = F.copy()
    edge_faces: dict[tuple[int, int], list[int]] = {}
    for f, tri in enumerate(F):
        for k in range(3):
            e = (int(min(tri[k], tri[(k + 1) % 3])), int(max(tri[k], tri[(k + 1) % 3])))
            edge_faces.setdefault(e, []).append(f)
    done = 0
    touched: set[int] = set()
    for f in bad:
        if f in touched:
            continue
        tri = F[f]
        for k in range(3):
            i, j = int(tri[k]), int(tri[(k + 1) % 3])
            fs = edge_faces.get((min(i, j), max(i, j)), [])
            if len(fs) != 2:
                continue
            g = fs[0] if fs[1] == f else fs[1]
            if g in touched:
                continue
            p = int(tri[(k + 2) % 3])
            other = F[g]
            q = int([x for x in other if x != i and x != j][0])
            n1, n2 = np.array([p, i, q]), np.array([p, q, j])
            ok = True
            for V in (Vs, Vt):
                if _areas(V, np.array([n1, n2])).min() <= 0:
                    ok = False
            if ok:
                F[f], F[g] = n1, n2
                touched.update((f, g))
                done += 1
                break
    return F, done


def _collapse_slivers(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, fixed: BoolArray, passes: int
) -> tuple[IntArray, int]:
    """Collapse free vertices onto a neighbour where that raises the local minimum angle.

    A free (interior, not fixed) vertex v is merged into the neighbour u that
    gives the largest smallest angle over v's new fan in *both* meshes,
    provided every new triangle is positive in both, that angle is larger
    than before, and the edge uv passes the link condition (u and v share
    exactly the two vertices opposite uv). This removes the slivers the
    refinement leaves next to edge crossings without creating flips.

    Returns
    -------
    F : (m', 3) int64
        Triangles; unreferenced vertices are left in place.
    collapsed : int
    """
    F = F.copy()
    alive = np.ones(F.shape[0], dtype=bool)
    total = 0
    n = Xs.shape[0]
    for _ in range(passes):
        vf = [set(fs) for fs in _vertex_faces(F[alive], n)]
        idx = np.flatnonzero(alive)
        vf = [{int(idx[f]) for f in fs} for fs in vf]
        ang = np.minimum(_face_min_angles(Xs, F), _face_min_angles(Xt, F))
        worst = np.full(n, 180.0)
        np.minimum.at(worst, F[alive].ravel(), np.repeat(ang[alive], 3))
        touched = np.zeros(n, dtype=bool)
        done = 0
        for v in np.argsort(worst):
            v = int(v)
            if fixed[v] or touched[v] or not vf[v] or worst[v] >= 30.0:
                continue
            faces = sorted(vf[v])
            nbrs = {int(w) for f in faces for w in F[f]} - {v}
            best_u, best = -1, worst[v]
            for u in nbrs:
                shared = [f for f in faces if u in F[f]]
                if len(shared) != 2:
                    continue
                common = ({int(w) for f in vf[u] for w in F[f]} & nbrs) - {u}
                if len(common) != 2:
                    continue
                new = np.array([F[f] for f in faces if f not in shared])
                new[new == v] = u
                if _areas(Xs, new).min() <= 0 or _areas(Xt, new).min() <= 0:
                    continue
                a = min(min_triangle_angle(Xs, new), min_triangle_angle(Xt, new))
                if a > best + 1e-9:
                    best_u, best = u, a
            if best_u < 0:
                continue
            u = best_u
            for f in faces:
                if u in F[f]:
                    alive[f] = False
                    for w in F[f]:
                        vf[int(w)].discard(f)
                else:
                    F[f][F[f] == v] = u
                    vf[u].add(f)
            vf[v] = set()
            touched[list(nbrs)] = True
            done += 1
        total += done
        if done == 0:
            break
    return F[alive], total


def _face_min_angles(V: FloatArray, F: IntArray) -> FloatArray:
    """Smallest corner angle of every triangle, degrees (0 for a flipped one)."""
    out = np.full(F.shape[0], 180.0)
    for k in range(3):
        a = V[F[:, (k + 1) % 3]] - V[F[:, k]]
        b = V[F[:, (k + 2) % 3]] - V[F[:, k]]
        cos = np.einsum("ij,ij->i", a, b) / np.maximum(
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300
        )
        out = np.minimum(out, np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.where(_areas(V, F) > 0, out, 0.0)


def _tri_min_angle(V: FloatArray, tris: IntArray) -> float:
    return min_triangle_angle(V, tris) if _areas(V, tris).min() > 0 else -1.0


def _quality_flips(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, passes: int
) -> tuple[IntArray, int]:
    """Flip interior edges when that raises the smaller of the two meshes' minimum angles."""
    F = F.copy()
    total = 0
    for _ in range(passes):
        edge_faces: dict[tuple[int, int], list[int]] = {}
        for f, tri in enumerate(F):
            for k in range(3):
                i, j = int(tri[k]), int(tri[(k + 1) % 3])
                edge_faces.setdefault((min(i, j), max(i, j)), []).append(f)
        touched: set[int] = set()
        done = 0
        for (i, j), fs in edge_faces.items():
            if len(fs) != 2 or fs[0] in touched or fs[1] in touched:
                continue
            f, g = fs
            tf = F[f]
            k = int(np.flatnonzero((tf != i) & (tf != j))[0])
            p = int(tf[k])
            a, b = int(tf[(k + 1) % 3]), int(tf[(k + 2) % 3])  # edge a→b in f, p opposite
            q = int([x for x in F[g] if x != a and x != b][0])
            old = np.array([F[f], F[g]])
            new = np.array([[p, a, q], [p, q, b]])
            before = min(_tri_min_angle(Xs, old), _tri_min_angle(Xt, old))
            after = min(_tri_min_angle(Xs, new), _tri_min_angle(Xt, new))
            if after > before + 1e-9:
                F[f], F[g] = new
                touched.update((f, g))
                done += 1
        total += done
        if done == 0:
            break
    return F, total


def _polyline_eval(poly: FloatArray, u: FloatArray) -> FloatArray:
    """Points at normalised arc-length parameters ``u`` in [0, 1] of an open polyline."""
    seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    L = cum[-1]
    s = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0) * L
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, poly.shape[0] - 2)
    d = cum[i + 1] - cum[i]
    w = np.where(d > 0, (s - cum[i]) / np.where(d > 0, d, 1.0), 0.0)
    return np.asarray(poly[i] + w[:, None] * (poly[i + 1] - poly[i]), dtype=np.float64)


def _polyline_params(poly: FloatArray) -> FloatArray:
    """Normalised arc-length parameters of the inner vertices of an open polyline."""
    seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    cum = np.cumsum(seg)
    return np.asarray(cum[:-1] / cum[-1], dtype=np.float64)


def _consistent_arc(
    ps: FloatArray, pt: FloatArray, h_s: float, h_t: float
) -> tuple[FloatArray, FloatArray]:
    """Corresponding points on two open polylines (start included, end excluded).

    The inner vertices of *both* polylines are kept: their normalised
    arc-length parameters are merged (a source and a target parameter closer
    than a quarter of the spacing are paired instead of both inserted), then
    every resulting piece is split into equally many parts, at most ``h_s``
    (source) and ``h_t`` (target) long.
    """
    us = _polyline_params(ps)
    ut = _polyline_params(pt)
    us = us[(us > 1e-12) & (us < 1 - 1e-12)]
    ut = ut[(ut > 1e-12) & (ut < 1 - 1e-12)]
    tol = 0.25 / (max(len(us), len(ut)) + 1)
    events = sorted([(float(u), 0) for u in us] + [(float(u), 1) for u in ut])
    a: list[float] = [0.0]
    b: list[float] = [0.0]
    i = 0
    while i < len(events):
        u, who = events[i]
        if i + 1 < len(events) and events[i + 1][1] != who and events[i + 1][0] - u < tol:
            v = events[i + 1][0]
            a.append(u if who == 0 else v)
            b.append(v if who == 0 else u)
            i += 2
        else:
            a.append(u)
            b.append(u)
            i += 1
    a.append(1.0)
    b.append(1.0)
    Xs = _polyline_eval(ps, np.array(a))
    Xt = _polyline_eval(pt, np.array(b))
    es, et = np.diff(Xs, axis=0), np.diff(Xt, axis=0)
    pieces = np.maximum(
        np.ceil(np.linalg.norm(es, axis=1) / h_s), np.ceil(np.linalg.norm(et, axis=1) / h_t)
    ).astype(np.int64)
    pieces = np.maximum(pieces, 1)
    outs, outt = [], []
    for j in range(es.shape[0]):
        w = np.arange(pieces[j])[:, None] / pieces[j]
        outs.append(Xs[j] + w * es[j])
        outt.append(Xt[j] + w * et[j])
    return np.vstack(outs), np.vstack(outt)


def _ring_arc(ring: FloatArray, s0: float, s1: float) -> FloatArray:
    """The part of a closed ring from arc length s0 forward to s1 (a full loop if equal)."""
    cum, L = _ring_params(ring)
    length = (s1 - s0) % L
    if length <= 1e-12 * L:
        length = L
    inner = (cum[:-1] - s0) % L
    order = np.argsort(inner)
    keep = order[(inner[order] > 1e-12 * L) & (inner[order] < length - 1e-12 * L)]
    ends = _eval_ring(ring, np.array([s0, s0 + length]))
    return np.vstack([ends[:1], ring[keep], ends[1:]])


def _cut_candidates(shape: ShapeRings, h: int) -> tuple[IntArray, IntArray, FloatArray]:
    """Straight segments from outer vertex p to vertex q of hole h inside the shape, shortest first."""
    outer, hole = shape.outer, shape.holes[h]
    P = np.repeat(np.arange(outer.shape[0]), hole.shape[0])
    Q = np.tile(np.arange(hole.shape[0]), outer.shape[0])
    length = np.linalg.norm(outer[P] - hole[Q], axis=1)
    order = np.argsort(length, kind="stable")[:4000]
    P, Q, length = P[order], Q[order], length[order]
    A = np.vstack(shape.rings)
    B = np.vstack([np.roll(r, -1, axis=0) for r in shape.rings])
    ring_of = np.concatenate([np.full(r.shape[0], k) for k, r in enumerate(shape.rings)])
    idx = np.concatenate([np.arange(r.shape[0]) for r in shape.rings])
    nxt = np.concatenate([(np.arange(r.shape[0]) + 1) % r.shape[0] for r in shape.rings])
    ok = np.zeros(P.shape[0], dtype=bool)
    for s in range(0, P.shape[0], 256):
        p, q = P[s : s + 256], Q[s : s + 256]
        a, b = outer[p], hole[q]
        cross = _segments_cross(a[:, None], b[:, None], A[None], B[None])
        touches_p = (ring_of[None] == 0) & ((idx[None] == p[:, None]) | (nxt[None] == p[:, None]))
        touches_q = (ring_of[None] == h + 1) & (
            (idx[None] == q[:, None]) | (nxt[None] == q[:, None])
        )
        ok[s : s + 256] = ~np.any(cross & ~touches_p & ~touches_q, axis=1)
    mid = 0.5 * (outer[P] + hole[Q])
    ok &= points_in_shape(shape, mid)
    return P[ok], Q[ok], length[ok]


def _match_holes(source: ShapeRings, target: ShapeRings) -> list[int]:
    """Target hole for each source hole: the assignment nearest in bounding-box coordinates."""
    k = len(source.holes)

    def centres(shape: ShapeRings) -> FloatArray:
        lo, span = shape.outer.min(axis=0), np.ptp(shape.outer, axis=0)
        return np.array([(h.mean(axis=0) - lo) / span for h in shape.holes])

    cs, ct = centres(source), centres(target)
    if k <= 6:
        best = min(
            itertools.permutations(range(k)),
            key=lambda perm: sum(float(np.linalg.norm(cs[i] - ct[perm[i]])) for i in range(k)),
        )
        return list(best)
    out: list[int] = []
    for i in range(k):  # greedy for many holes
        d = np.linalg.norm(ct - cs[i], axis=1)
        d[out] = np.inf
        out.append(int(np.argmin(d)))
    return out


def _choose_cuts(
    source: ShapeRings,
    target: ShapeRings,
    s_par: FloatArray,
    t_par: FloatArray,
    hole_match: list[int],
) -> list[tuple[tuple[int, int, float], tuple[int, int, float]]]:
    """One straight cut per pair of holes, ``((p_s, q_s, s_s), (p_t, q_t, s_t))``.

    Both ends of a cut pair on the outer rings fall between the same two
    consecutive boundary anchors; among those the pair with the smallest sum
    of lengths (relative to the shapes' diagonals) is chosen.
    """
    cs, Ls = _ring_params(source.outer)
    ct, Lt = _ring_params(target.outer)
    diag_s = float(np.linalg.norm(np.ptp(source.outer, axis=0)))
    diag_t = float(np.linalg.norm(np.ptp(target.outer, axis=0)))
    k = s_par.shape[0]

    def interval(par: FloatArray, anchors: FloatArray, L: float) -> tuple[IntArray, FloatArray]:
        rel = (par[:, None] - anchors[None]) % L
        j = np.argmin(np.where(rel > 0, rel, np.inf), axis=1)  # last anchor before par
        span = (np.roll(anchors, -1) - anchors) % L
        span = np.where(span > 0, span, L)
        frac = rel[np.arange(par.shape[0]), j] / span[j]
        return j, frac

    cuts = []
    for hs, ht in enumerate(hole_match):
        Ps, Qs, ls = _cut_candidates(source, hs)
        Pt, Qt, lt = _cut_candidates(target, ht)
        if Ps.size == 0 or Pt.size == 0:
            raise HoleCorrespondenceError(
                f"no straight cut joins hole {hs if Ps.size == 0 else ht} of the "
                f"{'source' if Ps.size == 0 else 'target'} to its outer boundary"
            )
        js, fs = interval(cs[Ps], s_par, Ls)
        jt, ft = interval(ct[Pt], t_par, Lt)
        best: tuple[float, int, int] | None = None
        for j in range(k):
            ms = np.flatnonzero((js == j) & (fs > 1e-9) & (fs < 1 - 1e-9))
            mt = np.flatnonzero((jt == j) & (ft > 1e-9) & (ft < 1 - 1e-9))
            if ms.size == 0 or mt.size == 0:
                continue
            i_s, i_t = int(ms[0]), int(mt[0])  # shortest of each (candidates are sorted)
            cost = ls[i_s] / diag_s + lt[i_t] / diag_t
            if best is None or cost < best[0]:
                best = (cost, i_s, i_t)
        if best is None:
            raise HoleCorrespondenceError(
                f"hole {hs} of the source and hole {ht} of the target cannot be cut to the outer "
                "boundary between the same two boundary anchors"
            )
        _, i_s, i_t = best
        cuts.append(
            (
                (int(Ps[i_s]), int(Qs[i_s]), float(cs[Ps[i_s]])),
                (int(Pt[i_t]), int(Qt[i_t]), float(ct[Pt[i_t]])),
            )
        )
    return cuts


def _check_cuts_apart(shape: ShapeRings, cuts: list[tuple[int, int, float]], holes: list[int]) -> None:
    """Cuts of different holes must neither cross nor share an end."""
    for i in range(len(cuts)):
        for j in range(i):
            a0, a1 = shape.outer[cuts[i][0]], shape.holes[holes[i]][cuts[i][1]]
            b0, b1 = shape.outer[cuts[j][0]], shape.holes[holes[j]][cuts[j][1]]
            if cuts[i][0] == cuts[j][0] or bool(_segments_cross(a0, a1, b0, b1)):
                raise HoleCorrespondenceError(
                    f"the straight cuts of holes {holes[j]} and {holes[i]} meet; "
                    "add boundary anchors between the holes' nearest boundary points"
                )


def _find(parent: dict[int, int], f: int) -> int:
    """Union-find root with path halving."""
    while parent[f] != f:
        parent[f] = parent[parent[f]]
        f = parent[f]
    return f


def _disk_mesh(
    uid: IntArray, copies: dict[int, list[int]], cut_edges: set[tuple[int, int]], V: FloatArray, F: IntArray, n_u: int
) -> tuple[FloatArray, IntArray]:
    """Cut a triangulation open along the cut edges: vertices 0..nb−1 become the disk-ring entries.

    ``uid[i]`` is the triangulation vertex of disk-ring entry i; a vertex with
    several entries (``copies``) is split, each incident triangle getting the
    copy on its side of the cut (the copy whose next ring edge bounds that
    triangle's fan of triangles between cut edges).
    """
    nb = uid.shape[0]
    local = np.full(V.shape[0], -1, dtype=np.int64)
    for i in range(nb):
        local[uid[i]] = i
    local[n_u:] = nb + np.arange(V.shape[0] - n_u)
    Fd = local[F]
    vf = _vertex_faces(F, V.shape[0])
    for u, entries in copies.items():
        if len(entries) < 2:
            continue
        faces = vf[u]
        parent = {f: f for f in faces}
        by_edge: dict[int, list[int]] = {}
        for f in faces:
            for w in F[f]:
                w = int(w)
                if w != u and (min(u, w), max(u, w)) not in cut_edges:
                    by_edge.setdefault(w, []).append(f)
        for fs in by_edge.values():
            for g in fs[1:]:
                parent[_find(parent, g)] = _find(parent, fs[0])
        for i in entries:
            w = int(uid[(i + 1) % nb])
            for f in faces:
                tri = F[f]
                k = int(np.flatnonzero(tri == u)[0])
                if int(tri[(k + 1) % 3]) == w:
                    root = _find(parent, f)
                    for g in faces:
                        if _find(parent, g) == root:
                            kk = int(np.flatnonzero(F[g] == u)[0])
                            Fd[g, kk] = i
                    break
    X = np.zeros((nb + V.shape[0] - n_u, 2))
    X[:nb] = V[uid]
    X[nb:] = V[n_u:]
    return X, Fd


def _unique_edges(F: IntArray) -> IntArray:
    E = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    return np.asarray(np.unique(E, axis=0), dtype=np.int64)


def _proper_crossings(
    a0: FloatArray, a1: FloatArray, b0: FloatArray, b1: FloatArray
) -> tuple[IntArray, IntArray, FloatArray]:
    """Pairs (i, j) of segments a_i, b_j crossing at an inner point of both, and the points."""
    ca, cb = 0.5 * (a0 + a1), 0.5 * (b0 + b1)
    ra = 0.5 * np.linalg.norm(a1 - a0, axis=1)
    rb = 0.5 * np.linalg.norm(b1 - b0, axis=1)
    tree = cKDTree(cb)
    pairs = tree.query_ball_point(ca, ra + (rb.max() if rb.size else 0.0))
    I = np.repeat(np.arange(len(pairs)), [len(p) for p in pairs]).astype(np.int64)
    J = np.concatenate([np.asarray(p, dtype=np.int64) for p in pairs]) if len(pairs) else I
    if I.size == 0:
        return I, J, np.zeros((0, 2))
    d = a1[I] - a0[I]
    e = b1[J] - b0[J]
    den = d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]
    w = b0[J] - a0[I]
    safe = np.where(den != 0, den, 1.0)
    s = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / safe
    t = (w[:, 0] * d[:, 1] - w[:, 1] * d[:, 0]) / safe
    eps = 1e-9
    ok = (den != 0) & (s > eps) & (s < 1 - eps) & (t > eps) & (t < 1 - eps)
    return I[ok], J[ok], a0[I[ok]] + s[ok, None] * d[ok]


def overlay_triangle_count(
    uv_s: FloatArray, F_s: IntArray, uv_t: FloatArray, F_t: IntArray, nb: int
) -> int:
    """Triangles of a triangulated overlay of two triangulations of the same convex polygon.

    Parameters
    ----------
    uv_s, uv_t : (n_s, 2), (n_t, 2) float64
        Vertices; the first ``nb`` of each are the shared polygon corners.
    F_s, F_t : (m_s, 3), (m_t, 3) int64
    nb : int

    Returns
    -------
    int
        ``2 V_o − nb − 2`` (Euler's formula for a triangulated polygon) with
        ``V_o = n_s + n_t − nb + X`` the overlay's vertices, X the proper
        crossings of edges of one triangulation with edges of the other.
        This is the size an edge-intersection method (the paper's refs. 9, 18)
        produces, against which the compatible triangulation is compared.

    Examples
    --------
    >>> import numpy as np
    >>> sq = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])
    >>> overlay_triangle_count(sq, np.array([[0, 1, 2], [0, 2, 3]]), sq, np.array([[0, 1, 3], [1, 2, 3]]), 4)
    4
    """
    Es, Et = _unique_edges(F_s), _unique_edges(F_t)
    _, _, X = _proper_crossings(uv_s[Es[:, 0]], uv_s[Es[:, 1]], uv_t[Et[:, 0]], uv_t[Et[:, 1]])
    v = uv_s.shape[0] + uv_t.shape[0] - nb + X.shape[0]
    return int(2 * v - nb - 2)


def _edges_meeting_triangle(tri: FloatArray, uv: FloatArray, E: IntArray) -> BoolArray:
    """(e,) bool: edges ``E`` of a triangulation ``uv`` that meet the inside of triangle ``tri`` (3, 2).

    An edge meets it when an end lies strictly inside or the edge properly
    crosses a side: exactly the edges along which a piecewise-linear map on
    that triangulation can bend inside ``tri``.
    """
    a, b, c = tri
    det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if det == 0:
        return np.zeros(E.shape[0], dtype=bool)
    d = uv - a
    l1 = (d[:, 0] * (c[1] - a[1]) - d[:, 1] * (c[0] - a[0])) / det
    l2 = ((b[0] - a[0]) * d[:, 1] - (b[1] - a[1]) * d[:, 0]) / det
    inside = (l1 > 1e-12) & (l2 > 1e-12) & (1 - l1 - l2 > 1e-12)
    hit = inside[E[:, 0]] | inside[E[:, 1]]
    p0, p1 = uv[E[:, 0]], uv[E[:, 1]]
    e = p1 - p0
    for s in range(3):
        q0, q1 = tri[s], tri[(s + 1) % 3]
        f = q1 - q0
        den = e[:, 0] * f[1] - e[:, 1] * f[0]
        w = q0 - p0
        safe = np.where(den != 0, den, 1.0)
        u = (w[:, 0] * f[1] - w[:, 1] * f[0]) / safe
        v = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / safe
        hit |= (den != 0) & (u > 1e-12) & (u < 1 - 1e-12) & (v > 1e-12) & (v < 1 - 1e-12)
    return np.asarray(hit)


def _vertices_inside_triangle(tri: FloatArray, uv: FloatArray) -> IntArray:
    """Indices of the points ``uv`` strictly inside triangle ``tri`` (3, 2), either orientation."""
    a, b, c = tri
    det = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if det == 0:
        return np.zeros(0, dtype=np.int64)
    d = uv - a
    l1 = (d[:, 0] * (c[1] - a[1]) - d[:, 1] * (c[0] - a[0])) / det
    l2 = ((b[0] - a[0]) * d[:, 1] - (b[1] - a[1]) * d[:, 0]) / det
    return np.flatnonzero((l1 > 1e-12) & (l2 > 1e-12) & (1 - l1 - l2 > 1e-12))


def _triangulate_deduplicated(verts: FloatArray, segs: IntArray) -> tuple[FloatArray, IntArray]:
    """:func:`triangulate_segments` after merging coincident vertices (first copy kept).

    Output vertex i < len(verts) is input vertex i (a merged copy takes its
    first copy's position and is unreferenced), so indices stay valid.
    """
    scale = float(np.abs(verts).max()) or 1.0
    _, first, inv = np.unique(
        np.round(verts / scale, 11), axis=0, return_index=True, return_inverse=True
    )
    inv = inv.reshape(-1)
    rep = first[inv]  # each vertex's first copy
    keep = np.sort(first)
    newidx = np.full(verts.shape[0], -1, dtype=np.int64)
    newidx[keep] = np.arange(keep.size)
    s = newidx[rep[segs]]
    s = s[s[:, 0] != s[:, 1]]
    s = np.unique(np.sort(s, axis=1), axis=0)
    V, F = triangulate_segments(verts[keep], s)
    # back to the caller's numbering: kept vertices at their own index, Steiner points after
    out_idx = np.concatenate([keep, verts.shape[0] + np.arange(V.shape[0] - keep.size)])
    X = np.zeros((verts.shape[0] + V.shape[0] - keep.size, 2))
    X[: verts.shape[0]] = verts[rep]
    X[out_idx] = V
    return X, out_idx[F]


def _map_back(loc: PointLocator, F: IntArray, X: FloatArray, P: FloatArray) -> FloatArray:
    return np.asarray(loc.locate(P).interpolate(F, X), dtype=np.float64)


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
        anchors only: see Notes).

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

    Notes
    -----
    Each shape's map from the parameter polygon is the inverse of a Floater
    embedding of its own triangulation, a piecewise-linear homeomorphism; a
    merged triangle can only flip where it straddles that map's kinks. Every
    triangle flipped in either shape is refined (the shape triangulation's
    vertices inside it, or else the crossings of its edges, are added to the
    merged points and the set is re-triangulated). Once every merged triangle
    lies inside one triangle of each parameterisation (the overlay), no
    triangle can flip, so the refinement ends with zero flips, normally long
    before the overlay's size (``overlay_triangles``) is reached.

    References
    ----------
    H.-B. Yan, S.-M. Hu, R. R. Martin, "Morphing based on strain field
    interpolation", Computer Animation and Virtual Worlds 15 (2004) 443–452,
    doi:10.1002/cav.48. M. S. Floater, "Mean value coordinates", CAGD 20
    (2003) 19–27, doi:10.1016/S0167-8396(03)00002-5.
    """
    if len(source.holes) != len(target.holes):
        raise HoleCorrespondenceError(
            f"the source has {len(source.holes)} hole(s) and the target {len(target.holes)}: "
            "holes cannot correspond (a patch dissection needs equally many holes)"
        )
    anchors = np.asarray(anchors, dtype=np.float64)
    if anchors.ndim != 3 or anchors.shape[1:] != (2, 2):
        raise ValueError(f"anchors must have shape (a, 2, 2), got {anchors.shape}")
    for side, shape in ((0, source), (1, target)):
        inside = points_in_shape(shape, anchors[:, side])
        if not np.all(inside):
            i = int(np.flatnonzero(~inside)[0])
            raise AnchorOutsideShapeError(
                f"anchor {i} {anchors[i, side].tolist()} lies outside the {'source' if side == 0 else 'target'} shape"
            )
    diag_s = float(np.linalg.norm(np.ptp(source.outer, axis=0)))
    diag_t = float(np.linalg.norm(np.ptp(target.outer, axis=0)))
    outer_s = ShapeRings(source.outer, (), ())
    outer_t = ShapeRings(target.outer, (), ())
    on_s = distance_to_rings(outer_s, anchors[:, 0]) <= ANCHOR_ON_BOUNDARY_RTOL * diag_s
    on_t = distance_to_rings(outer_t, anchors[:, 1]) <= ANCHOR_ON_BOUNDARY_RTOL * diag_t
    if np.any(on_s != on_t):
        i = int(np.flatnonzero(on_s != on_t)[0])
        raise ShapeError(f"anchor {i} lies on the boundary of one shape and inside the other")
    bidx = np.flatnonzero(on_s)
    if bidx.size == 0:
        raise TooFewAnchorsError(
            "at least one anchor must lie on the outer boundary of both shapes"
        )
    s_par = np.array([_project_on_ring(source.outer, anchors[i, 0])[0] for i in bidx])
    t_par = np.array([_project_on_ring(target.outer, anchors[i, 1])[0] for i in bidx])
    order = np.argsort(s_par)
    s_par, t_par, bidx = s_par[order], t_par[order], bidx[order]
    rot = np.argmin(t_par)
    if np.any(np.diff(np.roll(t_par, -rot)) <= 0):
        raise ShapeError("boundary anchors are in different orders along the two outer boundaries")
    if np.any(np.diff(s_par) <= 0):
        raise ShapeError("two boundary anchors coincide")
    inner = np.flatnonzero(~on_s)
    n_in = inner.size

    # ---- dissection into one disk patch: a straight cut from each hole to the outer ring
    if hole_match is not None:
        hole_match = [int(h) for h in hole_match]
        if sorted(hole_match) != list(range(len(target.holes))):
            raise ValueError(
                f"hole_match must be a permutation of 0..{len(target.holes) - 1}, got {hole_match}"
            )
    else:
        hole_match = _match_holes(source, target) if source.holes else []
    cuts = _choose_cuts(source, target, s_par, t_par, hole_match) if source.holes else []
    _check_cuts_apart(source, [c[0] for c in cuts], list(range(len(cuts))))
    _check_cuts_apart(target, [c[1] for c in cuts], hole_match)
    # corners on the outer ring, in source order from the first anchor: ("a", i) or ("c", hole)
    corners: list[tuple[str, int, float, float]] = [
        ("a", j, float(s_par[j]), float(t_par[j])) for j in range(bidx.size)
    ]
    corners += [("c", h, c[0][2], c[1][2]) for h, c in enumerate(cuts)]
    Ls, Lt = _ring_params(source.outer)[1], _ring_params(target.outer)[1]
    corners.sort(key=lambda c: (c[2] - s_par[0]) % Ls)
    t_rel = np.array([(c[3] - t_par[0]) % Lt for c in corners])
    if np.any(np.diff(t_rel) <= 0):
        raise HoleCorrespondenceError(
            "the holes' cuts reach the outer boundaries in different orders; add boundary anchors"
        )

    h_s = np.sqrt(2.0 * source.area / triangles_per_shape)
    h_t = np.sqrt(2.0 * target.area / triangles_per_shape)
    Bs_l: list[FloatArray] = []
    Bt_l: list[FloatArray] = []
    keys: list[tuple] = []
    cut_pts: dict[int, tuple[FloatArray, FloatArray]] = {}
    for h, ((ps, qs, _), (pt, qt, _)) in enumerate(cuts):
        hole_s, hole_t = source.holes[h], target.holes[hole_match[h]]
        cut_pts[h] = _consistent_arc(
            np.array([source.outer[ps], hole_s[qs]]),
            np.array([target.outer[pt], hole_t[qt]]),
            h_s,
            h_t,
        )
    anchor_pos = np.zeros(bidx.size, dtype=np.int64)
    K = len(corners)
    for c in range(K):
        kind, idx, s0, t0 = corners[c]
        _, _, s1, t1 = corners[(c + 1) % K]
        if kind == "c":
            h = idx
            (ps, qs, _), (pt, qt, _) = cuts[h]
            cs_, ct_ = cut_pts[h]
            m = cs_.shape[0]
            # along the cut to the hole, once round the hole, back along the cut
            Bs_l.append(cs_)
            Bt_l.append(ct_)
            keys += [("P", h)] + [("c", h, i) for i in range(1, m)]
            hole_s, hole_t = source.holes[h], target.holes[hole_match[h]]
            loop_s = np.vstack([np.roll(hole_s, -qs, axis=0), hole_s[qs : qs + 1]])
            loop_t = np.vstack([np.roll(hole_t, -qt, axis=0), hole_t[qt : qt + 1]])
            hs_pts, ht_pts = _consistent_arc(loop_s, loop_t, h_s, h_t)
            Bs_l.append(hs_pts)
            Bt_l.append(ht_pts)
            keys += [("Q", h)] + [("h", h, i) for i in range(1, hs_pts.shape[0])]
            back_s = np.vstack([hole_s[qs : qs + 1], cs_[1:][::-1]])
            back_t = np.vstack([hole_t[qt : qt + 1], ct_[1:][::-1]])
            Bs_l.append(back_s)
            Bt_l.append(back_t)
            keys += [("Q", h)] + [("c", h, i) for i in range(m - 1, 0, -1)]
        else:
            anchor_pos[idx] = sum(x.shape[0] for x in Bs_l)
        arc_s, arc_t = _consistent_arc(
            _ring_arc(source.outer, s0, s1), _ring_arc(target.outer, t0, t1), h_s, h_t
        )
        Bs_l.append(arc_s)
        Bt_l.append(arc_t)
        start_key: tuple = ("P", idx) if kind == "c" else ("a", idx)
        keys += [start_key] + [("o", c, i) for i in range(1, arc_s.shape[0])]
    Bs, Bt = np.vstack(Bs_l), np.vstack(Bt_l)
    nb = Bs.shape[0]
    category = {"a": 0, "o": 0, "P": 0, "Q": 1, "h": 1, "c": 2}
    first: dict[tuple, int] = {}
    for i, key in enumerate(keys):
        first.setdefault(key, i)
    ukeys = sorted(first, key=lambda k: (category[k[0]], first[k]))
    kid = {k: j for j, k in enumerate(ukeys)}
    uid = np.array([kid[k] for k in keys], dtype=np.int64)
    n_u = len(ukeys)
    n_outer = sum(1 for k in ukeys if category[k[0]] == 0)
    n_hole = sum(1 for k in ukeys if category[k[0]] == 1)
    copies: dict[int, list[int]] = {}
    for i in range(nb):
        copies.setdefault(int(uid[i]), []).append(i)
    cut_edges: set[tuple[int, int]] = set()
    for h in cut_pts:
        path = [kid[("P", h)]]
        path += [kid[("c", h, i)] for i in range(1, cut_pts[h][0].shape[0])]
        path += [kid[("Q", h)]]
        for a, b in zip(path[:-1], path[1:], strict=True):
            cut_edges.add((min(a, b), max(a, b)))
    ring_edges = np.sort(np.c_[uid, np.roll(uid, -1)], axis=1)
    segs = np.unique(ring_edges, axis=0)

    # ---- patch triangulations, cut open into disks, and their mean-value maps
    meshes = []
    for B, shape, side, holes in (
        (Bs, source, 0, list(range(len(cuts)))),
        (Bt, target, 1, hole_match),
    ):
        U = np.zeros((n_u, 2))
        U[uid] = B
        V, F = triangulate_segments(
            U,
            segs,
            hole_points=np.array([point_inside_ring(shape.holes[h]) for h in holes]).reshape(-1, 2),
            points=anchors[inner, side],
            max_area=shape.area / triangles_per_shape,
            min_angle=min_angle,
            split_inner_segments=False,
        )
        meshes.append(_disk_mesh(uid, copies, cut_edges, V, F, n_u))

    def arcfrac(B: FloatArray) -> FloatArray:
        cum, L = _ring_params(B)
        return np.asarray(cum[:-1] / L, dtype=np.float64)

    ang = 2.0 * np.pi * 0.5 * (arcfrac(Bs) + arcfrac(Bt))
    circle = np.c_[np.cos(ang), np.sin(ang)]
    uvs = [_mean_value_map(X, F, nb, circle) for X, F in meshes]
    overlay = overlay_triangle_count(uvs[0], meshes[0][1], uvs[1], meshes[1][1], nb)

    # ---- merge the inner points of both parameterisations
    anchor_uv = 0.5 * (uvs[0][nb : nb + n_in] + uvs[1][nb : nb + n_in])
    P_s, P_t = uvs[0][nb + n_in :], uvs[1][nb + n_in :]
    fixed_pts = np.vstack([circle, anchor_uv]) if n_in else circle

    def spacing(P: FloatArray) -> FloatArray:
        if P.shape[0] < 2:
            return np.full(P.shape[0], np.inf)
        return np.asarray(cKDTree(P).query(P, k=2)[0][:, 1], dtype=np.float64)

    sp_s, sp_t = spacing(P_s), spacing(P_t)
    keep_s = np.ones(P_s.shape[0], dtype=bool)
    keep_t = np.ones(P_t.shape[0], dtype=bool)
    if P_s.shape[0] and P_t.shape[0]:
        dist, nn = cKDTree(P_s).query(P_t)
        keep_t = dist >= 0.5 * np.minimum(sp_t, sp_s[nn])
    apothem = np.cos(np.pi / max(nb, 3))
    for P, hh0, keep in ((P_s, sp_s, keep_s), (P_t, sp_t, keep_t)):
        if P.shape[0]:
            hh = np.minimum(hh0, 0.5 * apothem)
            keep &= (apothem - np.linalg.norm(P, axis=1) > 0.0) & (
                cKDTree(fixed_pts).query(P)[0] >= 0.5 * hh
            )
    merged = int((~keep_s).sum() + (~keep_t).sum())
    # merged points, keyed by (mesh, vertex) so that refinement can refer to them
    plist: list[FloatArray] = [anchor_uv[i] for i in range(n_in)]
    reg: dict[tuple[int, int], int] = {}
    for k, keep in ((0, keep_s), (1, keep_t)):
        for ii in np.flatnonzero(keep).tolist():
            reg[(k, nb + n_in + ii)] = len(plist)
            plist.append(uvs[k][nb + n_in + ii])

    def vidx(k: int, i: int) -> int:
        if i < nb:
            return i
        if (k, i) not in reg:
            reg[(k, i)] = len(plist)
            plist.append(uvs[k][i])
        return nb + reg[(k, i)]

    # ---- triangulate in the polygon, map back, refine where a triangle flips:
    # the edges of the parameterisation near a flipped triangle become constraints
    # (Triangle inserts their crossings), i.e. the overlay is built only there.
    locators = [PointLocator(uvs[k], meshes[k][1]) for k in (0, 1)]
    edges = [_unique_edges(meshes[k][1]) for k in (0, 1)]
    ring = np.c_[np.arange(nb), (np.arange(nb) + 1) % nb]
    used = [np.zeros(e.shape[0], dtype=bool) for e in edges]
    refinements = 0
    n_initial = len(plist)
    while True:
        con = np.vstack(
            [ring]
            + [
                np.array(
                    [[vidx(k, int(i)), vidx(k, int(j))] for i, j in edges[k][used[k]]],
                    dtype=np.int64,
                ).reshape(-1, 2)
                for k in (0, 1)
            ]
        )
        UV, F = _triangulate_deduplicated(np.vstack([circle, np.array(plist).reshape(-1, 2)]), con)
        Xd = []
        for k in (0, 1):
            X = np.zeros((UV.shape[0], 2))
            X[:nb] = meshes[k][0][:nb]
            X[nb:] = _map_back(locators[k], meshes[k][1], meshes[k][0], UV[nb:])
            if n_in:
                X[nb : nb + n_in] = anchors[inner, k]
            Xd.append(X)
        # cheap repair first (the paper's edge flips, valid in both meshes); only
        # the triangles it cannot fix are refined
        for _ in range(8):
            bad_any = np.union1d(
                np.flatnonzero(_areas(Xd[0], F) <= 0), np.flatnonzero(_areas(Xd[1], F) <= 0)
            )
            if bad_any.size == 0:
                break
            F, done = _edge_flips(Xd[0], Xd[1], F, bad_any)
            if done == 0:
                break
        bad = [np.flatnonzero(_areas(Xd[k], F) <= 0) for k in (0, 1)]
        if refinements >= max_refinements or (bad[0].size == 0 and bad[1].size == 0):
            break
        grew = False
        for k in (0, 1):
            for f in bad[k]:
                found = _vertices_inside_triangle(UV[F[f]], uvs[k]).tolist()
                fresh = [v for v in found if v >= nb and (k, v) not in reg]
                if fresh:  # first the kinks at the map's vertices
                    for v in fresh:
                        vidx(k, v)
                    grew = True
                    continue
                hit = _edges_meeting_triangle(UV[F[f]], uvs[k], edges[k]) & ~used[k]
                if np.any(hit):  # then its edges
                    used[k] |= hit
                    grew = True
        if not grew:
            break
        refinements += 1
    added = UV.shape[0] - nb - n_initial

    # ---- glue the cut: disk-ring entries that are copies become one vertex
    glue = np.concatenate([uid, n_u + np.arange(UV.shape[0] - nb)])
    F = glue[F]
    n = n_u + UV.shape[0] - nb
    Xs, Xt = np.zeros((n, 2)), np.zeros((n, 2))
    Xs[glue], Xt[glue] = Xd[0], Xd[1]
    # drop vertices left unreferenced by coincident refinement points
    referenced = np.zeros(n, dtype=bool)
    referenced[F.ravel()] = True
    referenced[: n_u + n_in] = True
    if not np.all(referenced):
        renum = np.cumsum(referenced) - 1
        F, Xs, Xt, n = renum[F], Xs[referenced], Xt[referenced], int(referenced.sum())
    fixed = np.zeros(n, dtype=bool)
    fixed[: n_outer + n_hole] = True
    fixed[n_u : n_u + n_in] = True

    rounds = 0
    for rounds in range(1, repair_rounds + 1):
        bad_s = np.flatnonzero(_areas(Xs, F) <= 0)
        bad_t = np.flatnonzero(_areas(Xt, F) <= 0)
        if bad_s.size == 0 and bad_t.size == 0:
            rounds -= 1
            break
        F, _ = _edge_flips(Xs, Xt, F, np.union1d(bad_s, bad_t))
        vf = _vertex_faces(F, n)
        for X_idx in (0, 1):
            X = Xs if X_idx == 0 else Xt
            badx = np.flatnonzero(_areas(X, F) <= 0)
            if badx.size:
                verts = {int(v) for v in F[badx].ravel()}
                for _ in range(min(rounds - 1, 3)):
                    verts |= {int(w) for v in verts for f in vf[v] for w in F[f]}
                X = _relocate(X, F, vf, verts, fixed)
                if X_idx == 0:
                    Xs = X
                else:
                    Xt = X
    collapsed = 0
    ids = np.arange(n)
    if simplify and not (np.any(_areas(Xs, F) <= 0) or np.any(_areas(Xt, F) <= 0)):
        F, collapsed = _collapse_slivers(Xs, Xt, F, fixed, passes=4)
        referenced = np.zeros(n, dtype=bool)
        referenced[F.ravel()] = True
        referenced[fixed] = True
        if not np.all(referenced):
            renum = np.cumsum(referenced) - 1
            F, Xs, Xt, fixed, n = (
                renum[F], Xs[referenced], Xt[referenced], fixed[referenced], int(referenced.sum())
            )
            ids = ids[referenced]
    # quality: edge flips that raise the worse of the two minimum angles, then
    # relax interior vertices towards their neighbours' mean where that stays valid
    for _ in range(smoothing_rounds):
        if np.any(_areas(Xs, F) <= 0) or np.any(_areas(Xt, F) <= 0):
            break
        F, _ = _quality_flips(Xs, Xt, F, passes=3)
        vf = _vertex_faces(F, n)
        for X in (Xs, Xt):
            for v in range(n):
                if fixed[v]:
                    continue
                ea, eb = _one_ring_edges(F, vf[v], v)
                one_ring = np.unique(np.r_[ea, eb])
                old = X[v].copy()
                tris = np.array(F[vf[v]])
                before = min_triangle_angle(X, tris)
                X[v] = X[one_ring].mean(axis=0)
                if _areas(X, tris).min() <= 0 or min_triangle_angle(X, tris) < before:
                    X[v] = old

    anchor_vertices = np.zeros(anchors.shape[0], dtype=np.int64)
    anchor_vertices[bidx] = uid[anchor_pos]
    anchor_vertices[inner] = np.searchsorted(ids, n_u + np.arange(n_in))
    return CompatibleTriangulation(
        source_V=Xs,
        target_V=Xt,
        F=F,
        anchor_vertices=anchor_vertices,
        boundary_vertices=n_outer,
        flipped=(int(np.sum(_areas(Xs, F) <= 0)), int(np.sum(_areas(Xt, F) <= 0))),
        min_angle=(min_triangle_angle(Xs, F), min_triangle_angle(Xt, F)),
        merged_points=merged,
        repair_rounds=rounds,
        hole_vertices=n_hole,
        refinement_points=added,
        refinement_rounds=refinements,
        overlay_triangles=overlay,
    )
