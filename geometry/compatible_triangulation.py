"""Compatible (isomorphic) triangulations of two planar shapes ("From Objects to Isomorphic Meshes").

Follows the second half of Yan, Hu and Martin (2004) for one patch per
shape (shapes without holes):

1. **Consistent boundaries.** Anchors on the outer boundary split both rings
   into corresponding arcs. On each arc the vertices of *both* shapes are
   kept (their normalised arc-length positions are merged, and a source and a
   target vertex closer than a quarter of the local spacing are paired
   instead of both being inserted), so no corner of either shape is lost.
2. **Patch triangulation.** Each shape is triangulated (constrained Delaunay,
   no Steiner points on the boundary, quality refinement inside).
3. **Mean-value parameterisation** (Floater 2003) of each onto the same convex
   polygon inscribed in the unit circle; the corners sit at the mean of the
   two shapes' normalised arc lengths (a careful variant of the paper's
   regular n-gon: with hundreds of unevenly spaced boundary points a regular
   n-gon distorts both maps needlessly).
4. **Merge** the interior points of both parameterisations (points closer than
   a threshold are merged), triangulate the merged set in the polygon
   (constrained Delaunay) and **map back** through each parameterisation
   (barycentric coordinates). Anchors inside the shapes become vertices whose
   positions are the anchors themselves.
5. **Repair flips**: interior edge flips valid in both meshes, then moving an
   interior vertex of a folded one-ring (in that mesh only — the two meshes
   share connectivity, not positions) to the Chebyshev centre of its one-ring
   kernel (a small linear programme); repeated a few rounds.
6. **Quality**: interior vertices relaxed towards their kernel centres where
   that keeps every triangle positive, in each mesh.

Shapes with holes need the paper's dissection into patches, which is not
implemented: they raise :class:`~geometry.shape_rings.HoleCorrespondenceError`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog
from scipy.spatial import cKDTree

from ._typing import FloatArray, IntArray
from .locate_points import locate_points
from .mean_value_weights import mean_value_laplacian
from .shape_rings import (
    AnchorOutsideShapeError,
    HoleCorrespondenceError,
    ShapeError,
    ShapeRings,
    TooFewAnchorsError,
    distance_to_rings,
    points_in_shape,
)
from .sparse_factor import factorize
from .triangulate_shape import triangulate_polygon

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
        Rounds of flip repair used.
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
    """Arc-length parameter in [0, L), closest point, distance; snaps to a near vertex."""
    a, b = ring, np.roll(ring, -1, axis=0)
    e = b - a
    ee = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", p[None] - a, e) / ee, 0.0, 1.0)
    q = a + t[:, None] * e
    d = np.linalg.norm(q - p[None], axis=1)
    i = int(np.argmin(d))
    cum, _L = _ring_params(ring)
    ti = float(t[i])
    if ti < 0.25:
        ti = 0.0
    elif ti > 0.75:
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


def _consistent_boundary(
    src: FloatArray, tgt: FloatArray, s_anchor: FloatArray, t_anchor: FloatArray
) -> tuple[FloatArray, FloatArray, IntArray]:
    """Corresponding boundary points of both rings; returns (Bs, Bt, anchor positions in B)."""
    cs, Ls = _ring_params(src)
    ct, Lt = _ring_params(tgt)
    k = s_anchor.shape[0]
    Bs: list[FloatArray] = []
    Bt: list[FloatArray] = []
    anchor_idx = np.zeros(k, dtype=np.int64)
    for j in range(k):
        s0, s1 = s_anchor[j], s_anchor[(j + 1) % k]
        t0, t1 = t_anchor[j], t_anchor[(j + 1) % k]
        ls = (s1 - s0) % Ls if k > 1 else Ls
        lt = (t1 - t0) % Lt if k > 1 else Lt
        us = np.sort(((cs[:-1] - s0) % Ls) / ls)
        ut = np.sort(((ct[:-1] - t0) % Lt) / lt)
        us = us[(us > 1e-12) & (us < 1 - 1e-12)]
        ut = ut[(ut > 1e-12) & (ut < 1 - 1e-12)]
        spacing = 1.0 / (max(len(us), len(ut)) + 1)
        tol = 0.25 * spacing
        events = sorted([(u, 0) for u in us] + [(u, 1) for u in ut])
        merged: list[tuple[float, float]] = []  # (param in source arc, param in target arc)
        i = 0
        while i < len(events):
            u, who = events[i]
            if i + 1 < len(events) and events[i + 1][1] != who and events[i + 1][0] - u < tol:
                v = events[i + 1][0]
                merged.append((u, v) if who == 0 else (v, u))
                i += 2
            else:
                merged.append((u, u))
                i += 1
        anchor_idx[j] = len(Bs)
        ps = np.array([0.0] + [m[0] for m in merged])
        pt = np.array([0.0] + [m[1] for m in merged])
        Bs.extend(_eval_ring(src, s0 + ps * ls))
        Bt.extend(_eval_ring(tgt, t0 + pt * lt))
    return np.array(Bs), np.array(Bt), anchor_idx


def _subdivide_boundary(
    Bs: FloatArray, Bt: FloatArray, anchor_pos: IntArray, h_s: float, h_t: float
) -> tuple[FloatArray, FloatArray, IntArray]:
    """Split corresponding boundary edges into equally many pieces, at most h long."""
    es = np.roll(Bs, -1, axis=0) - Bs
    et = np.roll(Bt, -1, axis=0) - Bt
    pieces = np.maximum(
        np.ceil(np.linalg.norm(es, axis=1) / h_s), np.ceil(np.linalg.norm(et, axis=1) / h_t)
    ).astype(np.int64)
    pieces = np.maximum(pieces, 1)
    start = np.concatenate([[0], np.cumsum(pieces)[:-1]])
    outs, outt = [], []
    for j in range(Bs.shape[0]):
        u = np.arange(pieces[j])[:, None] / pieces[j]
        outs.append(Bs[j] + u * es[j])
        outt.append(Bt[j] + u * et[j])
    return np.vstack(outs), np.vstack(outt), start[anchor_pos]


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


def compatible_triangulation(
    source: ShapeRings,
    target: ShapeRings,
    anchors: FloatArray,
    *,
    triangles_per_shape: int = 200,
    min_angle: float = 25.0,
    repair_rounds: int = 16,
    smoothing_rounds: int = 3,
) -> CompatibleTriangulation:
    """Build two meshes with identical connectivity covering two planar shapes.

    Parameters
    ----------
    source, target : ShapeRings
        Validated shapes without holes.
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
        Rounds of flip repair (edge flips, then kernel relocation).
    smoothing_rounds : int, optional
        Rounds of interior-vertex relaxation after repair.

    Returns
    -------
    CompatibleTriangulation
        ``flipped`` reports any triangle the repair could not fix.

    Raises
    ------
    HoleCorrespondenceError
        If either shape has holes (patch dissection is not implemented).
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
    if source.holes or target.holes:
        raise HoleCorrespondenceError(
            f"shapes with holes ({len(source.holes)} and {len(target.holes)}) need patch dissection, "
            "which is not implemented; only hole-free shapes can be made compatible"
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
    on_s = distance_to_rings(source, anchors[:, 0]) <= ANCHOR_ON_BOUNDARY_RTOL * diag_s
    on_t = distance_to_rings(target, anchors[:, 1]) <= ANCHOR_ON_BOUNDARY_RTOL * diag_t
    if np.any(on_s != on_t):
        i = int(np.flatnonzero(on_s != on_t)[0])
        raise ShapeError(f"anchor {i} lies on the boundary of one shape and inside the other")
    bidx = np.flatnonzero(on_s)
    if bidx.size == 0:
        raise TooFewAnchorsError(
            "at least one anchor must lie on the outer boundary of both shapes"
        )
    proj_s = [_project_on_ring(source.outer, anchors[i, 0]) for i in bidx]
    proj_t = [_project_on_ring(target.outer, anchors[i, 1]) for i in bidx]
    s_par = np.array([p[0] for p in proj_s])
    t_par = np.array([p[0] for p in proj_t])
    order = np.argsort(s_par)
    s_par, t_par, bidx = s_par[order], t_par[order], bidx[order]
    rot = np.argmin(t_par)
    if np.any(np.diff(np.roll(t_par, -rot)) <= 0):
        raise ShapeError("boundary anchors are in different orders along the two outer boundaries")
    if np.any(np.diff(s_par) <= 0):
        raise ShapeError("two boundary anchors coincide")
    Bs, Bt, anchor_pos = _consistent_boundary(source.outer, target.outer, s_par, t_par)
    # Split long boundary edges (the same number of pieces in both shapes) so that
    # the triangulations can be refined without Steiner points on the boundary.
    h_s = np.sqrt(2.0 * source.area / triangles_per_shape)
    h_t = np.sqrt(2.0 * target.area / triangles_per_shape)
    Bs, Bt, anchor_pos = _subdivide_boundary(Bs, Bt, anchor_pos, h_s, h_t)
    nb = Bs.shape[0]

    # patch triangulations of each shape with the consistent boundary
    inner = np.flatnonzero(~on_s)
    meshes = []
    for B, shape, side in ((Bs, source, 0), (Bt, target, 1)):
        area = shape.area
        V, F = triangulate_polygon(
            B, points=anchors[inner, side], max_area=area / triangles_per_shape, min_angle=min_angle
        )
        meshes.append((V, F))

    # common convex polygon: mean normalised arc length of both boundaries
    def arcfrac(B: FloatArray) -> FloatArray:
        cum, L = _ring_params(B)
        return np.asarray(cum[:-1] / L, dtype=np.float64)

    ang = 2.0 * np.pi * 0.5 * (arcfrac(Bs) + arcfrac(Bt))
    circle = np.c_[np.cos(ang), np.sin(ang)]
    uvs = [_mean_value_map(V, F, nb, circle) for V, F in meshes]

    # merge interior points of both parameterisations
    n_in = inner.size
    anchor_uv = 0.5 * (uvs[0][nb : nb + n_in] + uvs[1][nb : nb + n_in])
    # Points of the two sets closer than half their own local spacing are merged
    # (the target point is dropped); points nearer the polygon than that are dropped.
    P_s, P_t = uvs[0][nb + n_in :], uvs[1][nb + n_in :]
    fixed_pts = np.vstack([circle, anchor_uv]) if n_in else circle

    def spacing(P: FloatArray) -> FloatArray:
        if P.shape[0] < 2:
            return np.full(P.shape[0], np.inf)
        return np.asarray(cKDTree(P).query(P, k=2)[0][:, 1], dtype=np.float64)

    h_s, h_t = spacing(P_s), spacing(P_t)
    keep_s = np.ones(P_s.shape[0], dtype=bool)
    keep_t = np.ones(P_t.shape[0], dtype=bool)
    if P_s.shape[0] and P_t.shape[0]:
        dist, nn = cKDTree(P_s).query(P_t)
        keep_t = dist >= 0.5 * np.minimum(h_t, h_s[nn])
    apothem = np.cos(np.pi / max(nb, 3))  # inscribed radius of the polygon (upper bound on spacing)
    for P, h, keep in ((P_s, h_s, keep_s), (P_t, h_t, keep_t)):
        if P.shape[0]:
            hh = np.minimum(h, 0.5 * apothem)
            keep &= (apothem - np.linalg.norm(P, axis=1) > 0.0) & (
                cKDTree(fixed_pts).query(P)[0] >= 0.5 * hh
            )
    merged = int((~keep_s).sum() + (~keep_t).sum())
    pts = np.vstack([anchor_uv.reshape(-1, 2), P_s[keep_s], P_t[keep_t]])
    UV, F = triangulate_polygon(circle, points=pts)

    # map back through each parameterisation
    out = []
    for (V, Fm), uv, B, side in ((meshes[0], uvs[0], Bs, 0), (meshes[1], uvs[1], Bt, 1)):
        X = np.zeros((UV.shape[0], 2))
        X[:nb] = B
        face, bary = locate_points(uv, Fm, UV[nb:], atol=1e-9)
        missing = face < 0
        if np.any(missing):  # round-off at the polygon's edges: nearest triangle centroid
            cen = uv[Fm].mean(axis=1)
            face[missing] = cKDTree(cen).query(UV[nb:][missing])[1]
            bary[missing] = 1.0 / 3.0
        X[nb:] = np.einsum("kj,kjd->kd", bary, V[Fm[face]])
        if n_in:
            X[nb : nb + n_in] = anchors[inner, side]
        out.append(X)
    Xs, Xt = out
    fixed = np.zeros(UV.shape[0], dtype=bool)
    fixed[: nb + n_in] = True

    rounds = 0
    for rounds in range(1, repair_rounds + 1):
        bad_s = np.flatnonzero(_areas(Xs, F) <= 0)
        bad_t = np.flatnonzero(_areas(Xt, F) <= 0)
        if bad_s.size == 0 and bad_t.size == 0:
            rounds -= 1
            break
        F, _ = _edge_flips(Xs, Xt, F, np.union1d(bad_s, bad_t))
        vf = _vertex_faces(F, UV.shape[0])
        for X_idx in (0, 1):
            X = Xs if X_idx == 0 else Xt
            bad = np.flatnonzero(_areas(X, F) <= 0)
            if bad.size:
                verts = {int(v) for v in F[bad].ravel()}
                # later rounds also move the neighbours: a vertex whose one-ring kernel is
                # empty can only be untangled when its neighbours move first
                for _ in range(min(rounds - 1, 3)):
                    verts |= {int(w) for v in verts for f in vf[v] for w in F[f]}
                X = _relocate(X, F, vf, verts, fixed)
                if X_idx == 0:
                    Xs = X
                else:
                    Xt = X
    # quality: edge flips that raise the worse of the two minimum angles, then
    # relax interior vertices towards their neighbours' mean where that stays valid
    for _ in range(smoothing_rounds):
        if np.any(_areas(Xs, F) <= 0) or np.any(_areas(Xt, F) <= 0):
            break
        F, _ = _quality_flips(Xs, Xt, F, passes=3)
        vf = _vertex_faces(F, UV.shape[0])
        for X in (Xs, Xt):
            for v in range(UV.shape[0]):
                if fixed[v]:
                    continue
                a, b = _one_ring_edges(F, vf[v], v)
                ring = np.unique(np.r_[a, b])
                old = X[v].copy()
                tris = np.array(F[vf[v]])
                before = min_triangle_angle(X, tris)
                X[v] = X[ring].mean(axis=0)
                if _areas(X, tris).min() <= 0 or min_triangle_angle(X, tris) < before:
                    X[v] = old

    return CompatibleTriangulation(
        source_V=Xs,
        target_V=Xt,
        F=F,
        anchor_vertices=_anchor_vertices(anchors.shape[0], bidx, anchor_pos, inner, nb),
        boundary_vertices=nb,
        flipped=(int(np.sum(_areas(Xs, F) <= 0)), int(np.sum(_areas(Xt, F) <= 0))),
        min_angle=(min_triangle_angle(Xs, F), min_triangle_angle(Xt, F)),
        merged_points=merged,
        repair_rounds=rounds,
    )


def _anchor_vertices(
    a: int, bidx: IntArray, anchor_pos: IntArray, inner: IntArray, nb: int
) -> IntArray:
    out = np.zeros(a, dtype=np.int64)
    out[bidx] = anchor_pos
    out[inner] = nb + np.arange(inner.size)
    return out
