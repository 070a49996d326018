"""Quality of two meshes with the same triangles: minimum angles, sliver collapse, quality edge flips."""

from __future__ import annotations

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray
from .flip_repair import _areas, _vertex_faces


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
    return float(_corner_min_angles(V, F).min(initial=180.0))


def _corner_min_angles(V: FloatArray, T: IntArray) -> FloatArray:
    """Smallest (unsigned) corner angle of every triangle, degrees, (m,).

    The arccos of each corner's cosine, ``e₁·e₂ / max(|e₁| |e₂|, 1e-300)`` clipped
    to [−1, 1] (a degenerate triangle gets 0). The arccos of the largest cosine: arccos
    and the conversion to degrees are monotone, so that is the smallest corner's value
    to the bit, with one arccos per triangle instead of three. The edges d₀₁, d₁₂, d₂₀
    serve every corner (corner 0's are d₀₁ and −d₂₀; a negation is exact), so each
    corner's cosine is the same floating-point number as from its own two edges. The
    callers pass the few triangles of a vertex's fan thousands of times: the cost is
    numpy's per-call overhead, which this halves.
    """
    x, y = V[:, 0][T], V[:, 1][T]  # (m, 3)
    x0, x1, x2 = x[:, 0], x[:, 1], x[:, 2]
    y0, y1, y2 = y[:, 0], y[:, 1], y[:, 2]
    ax, ay = x1 - x0, y1 - y0  # d01
    bx, by = x2 - x1, y2 - y1  # d12
    cx, cy = x0 - x2, y0 - y2  # d20
    la = np.sqrt(ax * ax + ay * ay)
    lb = np.sqrt(bx * bx + by * by)
    lc = np.sqrt(cx * cx + cy * cy)
    # corner 0: d01 · (−d20), corner 1: d12 · (−d01), corner 2: d20 · (−d12)
    c0 = -(ax * cx + ay * cy) / np.maximum(la * lc, 1e-300)
    c1 = -(bx * ax + by * ay) / np.maximum(lb * la, 1e-300)
    c2 = -(cx * bx + cy * by) / np.maximum(lc * lb, 1e-300)
    cmax = np.maximum(np.maximum(c0, c1), c2)
    return np.asarray(np.degrees(np.arccos(np.clip(cmax, -1.0, 1.0))), dtype=np.float64)


def _face_min_angles(V: FloatArray, F: IntArray) -> FloatArray:
    """Smallest corner angle of every triangle, degrees (0 for a flipped one): the
    :func:`_tri_quality` of each triangle, its -1 for a flipped one raised to 0."""
    return np.maximum(_tri_quality(V, F), 0.0)


def _tri_quality(V: FloatArray, T: IntArray) -> FloatArray:
    """Smallest angle of every triangle in degrees, -1 for one whose signed area is not positive."""
    return np.where(_areas(V, T) > 0, _corner_min_angles(V, T), -1.0)


def _flip_candidates(F: IntArray) -> tuple[IntArray, IntArray, IntArray]:
    """Every interior edge as its two faces (f, g) and the two triangles a flip would make.

    Edges come in the order of their first appearance in ``F`` (face by face,
    corner by corner); f is the first face listing the edge. Edges of one or of
    more than two faces are left out. Found by sorting edge keys (no Python loop).

    Returns
    -------
    fg : (e, 2) int64
        The faces f, g of each edge a→b (a→b in f's order).
    new : (e, 2, 3) int64
        ``[p, a, q]`` and ``[p, q, b]``, p opposite the edge in f, q in g.
    old : (e, 2, 3) int64
        ``F[f]`` and ``F[g]``.
    """
    F = np.asarray(F, dtype=np.int64)
    m = F.shape[0]
    if m == 0:
        none = np.zeros((0, 2, 3), dtype=np.int64)
        return np.zeros((0, 2), dtype=np.int64), none, none
    # corner k of face f starts the edge F[f, k] → F[f, k + 1]; slot 3 f + k
    start, end = F.ravel(), np.roll(F, -1, axis=1).ravel()
    key = np.minimum(start, end) * (int(F.max()) + 1) + np.maximum(start, end)
    order = np.argsort(key, kind="stable")  # each edge's slots, in face order
    sk = key[order]
    first = np.r_[True, sk[1:] != sk[:-1]]
    begin = np.flatnonzero(first)
    count = np.diff(np.r_[begin, sk.size])
    two = begin[count == 2]  # interior edges: exactly two faces
    s1, s2 = order[two], order[two + 1]
    seen = np.argsort(s1)  # edges in the order their first face lists them
    s1, s2 = s1[seen], s2[seen]
    f, ke = s1 // 3, s1 % 3
    g, kg = s2 // 3, s2 % 3
    a, b = F[f, ke], F[f, (ke + 1) % 3]
    p, q = F[f, (ke + 2) % 3], F[g, (kg + 2) % 3]  # opposite the edge in f and in g
    FG = np.stack([f, g], axis=1)
    new = np.stack([np.stack([p, a, q], axis=1), np.stack([p, q, b], axis=1)], axis=1)
    return FG, new, F[FG]


def _quality_flips(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, passes: int
) -> tuple[IntArray, int]:
    """Flip interior edges when that raises the smaller of the two meshes' minimum angles.

    Edges are visited in the order of their first face; an edge whose faces
    an earlier flip of the pass changed waits for the next pass. The angles
    of every candidate are computed at once at the start of a pass: the faces
    of an edge that is flipped are unchanged until then.
    """
    F = F.copy()
    total = 0
    for _ in range(passes):
        fg, new, old = _flip_candidates(F)
        if fg.shape[0] == 0:
            break

        def quality(T: IntArray) -> FloatArray:
            flat = T.reshape(-1, 3)
            q = np.minimum(_tri_quality(Xs, flat), _tri_quality(Xt, flat))
            return q.reshape(-1, 2).min(axis=1)

        better = quality(new) > quality(old) + 1e-9
        touched: set[int] = set()
        done = 0
        for e in np.flatnonzero(better).tolist():
            f, g = int(fg[e, 0]), int(fg[e, 1])
            if f in touched or g in touched:
                continue
            F[f], F[g] = new[e]
            touched.update((f, g))
            done += 1
        total += done
        if done == 0:
            break
    return F, total


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
            u = _collapse_choice(Xs, Xt, F, vf, faces, v, float(worst[v]))[0]
            if u < 0:
                continue
            touched[list(_collapse_into(F, vf, alive, v, u))] = True
            done += 1
        total += done
        if done == 0:
            break
    return F[alive], total


def _collapse_into(F: IntArray, vf: list[set[int]], alive: BoolArray, v: int, u: int) -> set[int]:
    """Collapse vertex ``v`` into its neighbour ``u``, in place.

    The faces holding both die (``alive`` False, dropped from ``vf``); the others
    of ``v`` name ``u`` instead. Returns ``v``'s former neighbours (``u`` among them).
    """
    faces = sorted(vf[v])
    nbrs = {int(w) for f in faces for w in F[f]} - {v}
    for f in faces:
        if u in F[f]:
            alive[f] = False
            for w in F[f]:
                vf[int(w)].discard(f)
        else:
            F[f][F[f] == v] = u
            vf[u].add(f)
    vf[v] = set()
    return nbrs


def _collapse_choice(
    Xs: FloatArray,
    Xt: FloatArray,
    F: IntArray,
    vf: list[set[int]],
    faces: list[int],
    v: int,
    worst: float,
) -> tuple[int, float]:
    """The neighbour u whose collapse v → u gives the largest smallest angle above ``worst``
    (-1 if none), and that angle (``worst`` if none).

    Candidates pass the link condition (uv in exactly two of v's faces, and u, v
    sharing exactly the two vertices opposite uv); the fans of all candidates are
    measured at once in both meshes, a candidate with a non-positive triangle in
    either excluded; a candidate replaces the best so far when its smallest angle
    is larger by more than 1e-9°, in the order of ``nbrs`` as a set.
    """
    # a fan is a handful of triangles: Python lists, not numpy calls on tiny arrays, and
    # the sets filled in the order of the faces' corners (so they iterate alike)
    rows = F[faces].tolist()  # k triangles
    nbrs = {w for r in rows for w in r} - {v}
    cand: list[int] = []
    fans: list[list[list[int]]] = []
    for u in nbrs:
        has_u = [u in r for r in rows]
        if sum(has_u) != 2:
            continue
        common = (set(F[list(vf[u])].ravel().tolist()) & nbrs) - {u}
        if len(common) != 2:
            continue
        cand.append(u)
        fans.append(
            [[u if w == v else w for w in r] for r, h in zip(rows, has_u, strict=True) if not h]
        )
    if not cand:
        return -1, worst
    sizes = np.array([len(f) for f in fans])
    T = np.array([r for f in fans for r in f], dtype=np.int64).reshape(-1, 3)
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    pos = np.minimum.reduceat(np.minimum(_areas(Xs, T), _areas(Xt, T)), starts)
    ang = np.minimum.reduceat(
        np.minimum(_corner_min_angles(Xs, T), _corner_min_angles(Xt, T)), starts
    )
    best_u, best = -1, worst
    for u, p, a in zip(cand, pos.tolist(), ang.tolist(), strict=True):
        if p > 0 and a > best + 1e-9:  # each candidate must beat the best so far by 1e-9
            best_u, best = u, a
    return best_u, best


def collapse_slivers(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, fixed: BoolArray
) -> tuple[FloatArray, FloatArray, IntArray, BoolArray, IntArray, int]:
    """:func:`_collapse_slivers` (4 passes), then the vertices no triangle uses dropped.

    Parameters
    ----------
    Xs, Xt : (n, 2) float64
        Unflipped meshes.
    F : (m, 3) int64
    fixed : (n,) bool

    Returns
    -------
    Xs, Xt : (n', 2) float64
    F : (m', 3) int64
    fixed : (n',) bool
    ids : (n',) int64
        Index before the collapse of each vertex kept.
    collapsed : int
    """
    n = Xs.shape[0]
    ids = np.arange(n)
    F, collapsed = _collapse_slivers(Xs, Xt, F, fixed, passes=4)
    referenced = np.zeros(n, dtype=bool)
    referenced[F.ravel()] = True
    referenced[fixed] = True
    if not np.all(referenced):
        renum = np.cumsum(referenced) - 1
        F, Xs, Xt, fixed = renum[F], Xs[referenced], Xt[referenced], fixed[referenced]
        ids = ids[referenced]
    return Xs, Xt, F, fixed, ids, collapsed


def improve_quality(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, fixed: BoolArray, smoothing_rounds: int
) -> IntArray:
    """Raise the minimum angles of two unflipped meshes with the same triangles, keeping them unflipped.

    Each round: edge flips that raise the worse of the two minimum angles, then
    each free vertex moved to its one-ring's mean in each mesh where that keeps
    its triangles positive and does not lower their smallest angle. Stops at
    once if a triangle is flipped.

    Parameters
    ----------
    Xs, Xt : (n, 2) float64
        Modified in place (vertex relaxation).
    F : (m, 3) int64
    fixed : (n,) bool
    smoothing_rounds : int

    Returns
    -------
    (m, 3) int64
        The triangles after the flips.
    """
    n = Xs.shape[0]
    for _ in range(smoothing_rounds):
        if np.any(_areas(Xs, F) <= 0) or np.any(_areas(Xt, F) <= 0):
            break
        F, _ = _quality_flips(Xs, Xt, F, passes=3)
        vf = _vertex_faces(F, n)
        free = [v for v in range(n) if not fixed[v] and vf[v]]
        fans = [F[vf[v]] for v in free]
        rings = [np.setdiff1d(fan, [v]) for v, fan in zip(free, fans, strict=True)]
        for X in (Xs, Xt):
            # every face's smallest angle, kept current as vertices move (angles are
            # per triangle, so a fan's are the same computed alone or with all faces)
            face_angle = _corner_min_angles(X, F)
            for v, tris, one_ring in zip(free, fans, rings, strict=True):
                old = X[v].copy()
                before = face_angle[vf[v]].min()
                X[v] = X[one_ring].mean(axis=0)
                after = _corner_min_angles(X, tris)
                if _areas(X, tris).min() <= 0 or after.min() < before:
                    X[v] = old
                else:
                    face_angle[vf[v]] = after
    return F
