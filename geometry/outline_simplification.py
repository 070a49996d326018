"""Simplify the rings of a 2D shape to a point budget, keeping features and anchors.

Visvalingam-Whyatt elimination over all rings at once: the vertex whose
triangle with its two neighbours has the least area goes first, its
neighbours' areas are updated, until the rings together have at most
``budget`` points. A vertex is never removed when it is protected (a feature
point of its ring, :func:`conformorph.geometry.outline_features.outline_features`, or a
point to keep), when its ring would fall below ``min_ring_points``, or when the
removal would break the shape: the new edge may cross no other edge of any
ring, and the removed triangle may contain no other vertex nor any interior
point to keep (so no hole leaves its outer ring and no interior anchor leaves
the shape). The result is therefore a valid shape whenever the input is.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._typing import BoolArray, FloatArray, IntArray
from .outline_features import FeatureOptions, outline_features


@dataclass(frozen=True)
class SimplifyOptions:
    """Options of :func:`simplify_rings`.

    Attributes
    ----------
    budget : int
        Most points over all rings (default 200, so that compatible meshes
        stay at a few hundred vertices).
    keep_features : bool
        Protect each ring's feature points (default True).
    min_saliency : float
        Only features at least this salient are protected (default 0.2,
        i.e. turning by 36 degrees or more).
    min_ring_points : int
        Fewest points left on a ring (default 4; a ring that has fewer keeps
        them all).
    point_tolerance : float
        A point to keep within this fraction of the shape's diameter of a
        vertex is that vertex; within it of an edge, it is inserted into the
        edge; farther, it is an interior point (default 1e-6).
    features : FeatureOptions
        Options of the feature detector.
    """

    budget: int = 200
    keep_features: bool = True
    min_saliency: float = 0.2
    min_ring_points: int = 4
    point_tolerance: float = 1e-6
    features: FeatureOptions = FeatureOptions()


@dataclass(frozen=True)
class SimplifiedRings:
    """Rings after :func:`simplify_rings`.

    Attributes
    ----------
    rings : list of (k_r, 2) float64
        Simplified rings, in the input's order and orientation.
    index : list of (k_r,) int64
        Input vertex index of each kept vertex; -1 for a point to keep that
        was inserted into an edge.
    protected : list of (k_r,) bool
        Which kept vertices were protected.
    reached_budget : bool
        False when every further removal was forbidden before the budget was
        reached.
    """

    rings: list[FloatArray]
    index: list[IntArray]
    protected: list[BoolArray]
    reached_budget: bool


def simplify_rings(
    rings: list[ArrayLike],
    *,
    keep_points: ArrayLike | None = None,
    options: SimplifyOptions | None = None,
) -> SimplifiedRings:
    """Visvalingam-Whyatt simplification of a shape's rings to a point budget.

    Parameters
    ----------
    rings : list of (n_r, 2) array_like
        Outer ring first, then holes; each closed, last point not repeated.
    keep_points : (q, 2) array_like, optional
        Points kept exactly, e.g. both sides' anchors of this shape: those on
        a ring stay (inserted into their edge if need be), interior ones
        stay inside the shape.
    options : SimplifyOptions, optional

    Returns
    -------
    SimplifiedRings

    Raises
    ------
    ValueError
        Rings not (n, 2) with n >= 3, non-finite values, or more protected
        points than the budget.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 100, endpoint=False)
    >>> circle = np.column_stack([np.cos(t), np.sin(t)])
    >>> out = simplify_rings([circle], options=SimplifyOptions(budget=12))
    >>> len(out.rings[0]), out.reached_budget
    (12, True)
    """
    opts = options or SimplifyOptions()
    R = [_as_ring(r) for r in rings]
    keep = (
        np.zeros((0, 2))
        if keep_points is None
        else np.asarray(keep_points, dtype=np.float64).reshape(-1, 2)
    )
    diameter = float(np.ptp(np.vstack(R), axis=0).max())
    tol = opts.point_tolerance * diameter
    R, src_index, prot, interior = _insert_keep_points(R, keep, tol)
    if opts.keep_features:
        for r, ring in enumerate(R):
            f = outline_features(ring, options=opts.features)
            prot[r][f.index[f.saliency >= opts.min_saliency]] = True
    n_prot = sum(int(np.count_nonzero(p)) for p in prot)
    floor = sum(min(len(r), opts.min_ring_points) for r in R)
    if max(n_prot, 0) > opts.budget:
        raise ValueError(f"{n_prot} protected points exceed the budget of {opts.budget}")
    alive, reached = _eliminate(R, prot, interior, max(opts.budget, floor), opts.min_ring_points)
    out_rings, out_index, out_prot = [], [], []
    start = 0
    for r, ring in enumerate(R):
        a = alive[start : start + len(ring)]
        out_rings.append(ring[a].copy())
        out_index.append(src_index[r][a])
        out_prot.append(prot[r][a])
        start += len(ring)
    return SimplifiedRings(out_rings, out_index, out_prot, reached and opts.budget >= floor)


def _as_ring(ring: ArrayLike) -> FloatArray:
    P = np.asarray(ring, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 3:
        raise ValueError(f"each ring must have shape (n, 2) with n >= 3, got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError("ring coordinates must be finite")
    return P


def _insert_keep_points(
    R: list[FloatArray], keep: FloatArray, tol: float
) -> tuple[list[FloatArray], list[IntArray], list[BoolArray], FloatArray]:
    """Protect the keep points at vertices, insert those on edges, return the interior ones."""
    rings = [r.copy() for r in R]
    index = [np.arange(len(r), dtype=np.int64) for r in R]
    prot = [np.zeros(len(r), dtype=bool) for r in R]
    interior = []
    for p in keep:
        best = (np.inf, -1, -1, 0.0)  # distance, ring, edge, parameter
        for r, ring in enumerate(rings):
            e = np.roll(ring, -1, axis=0) - ring
            t = np.clip(
                np.einsum("ij,ij->i", p - ring, e)
                / np.maximum(np.einsum("ij,ij->i", e, e), 1e-300),
                0,
                1,
            )
            d = np.linalg.norm(ring + t[:, None] * e - p, axis=1)
            k = int(np.argmin(d))
            if d[k] < best[0]:
                best = (float(d[k]), r, k, float(t[k]))
        dist, r, k, t = best
        if dist > tol:
            interior.append(p)
            continue
        ring = rings[r]
        n = len(ring)
        end = np.linalg.norm(ring[[k, (k + 1) % n]] - p, axis=1)
        if end.min() <= tol:
            prot[r][(k + int(np.argmin(end))) % n] = True
            continue
        rings[r] = np.insert(ring, k + 1, p, axis=0)
        index[r] = np.insert(index[r], k + 1, -1)
        prot[r] = np.insert(prot[r], k + 1, True)
    return rings, index, prot, np.array(interior, dtype=np.float64).reshape(-1, 2)


def _eliminate(
    R: list[FloatArray], prot: list[BoolArray], interior: FloatArray, budget: int, min_ring: int
) -> tuple[BoolArray, bool]:
    """Visvalingam elimination over all rings; which vertices stay, and whether the budget was met."""
    e = _Elimination(R, np.concatenate(prot), interior, min_ring)
    heap = [(e.area(i), i) for i in range(e.X.shape[0]) if not e.protected[i]]
    while True:
        heapq.heapify(heap)
        before = e.n_alive
        blocked = e.drain(heap, budget)
        if e.n_alive <= budget or e.n_alive == before or not blocked:
            break
        # a removal elsewhere may have unblocked these: try them again
        heap = [(e.area(i), i) for i in blocked if e.alive[i]]
    return e.alive, e.n_alive <= budget


class _Elimination:
    """State of the elimination: all rings' vertices in one array with ring-local links."""

    def __init__(
        self, R: list[FloatArray], protected: BoolArray, interior: FloatArray, min_ring: int
    ):
        self.X = np.vstack(R)
        sizes = np.array([len(r) for r in R])
        self.ring_of = np.repeat(np.arange(len(R)), sizes)
        offs = np.concatenate([[0], np.cumsum(sizes)])[self.ring_of]
        local = np.arange(self.X.shape[0]) - offs
        self.nxt = offs + (local + 1) % sizes[self.ring_of]
        self.prv = offs + (local - 1) % sizes[self.ring_of]
        self.alive = np.ones(self.X.shape[0], dtype=bool)
        self.protected = protected
        self.interior = interior
        self.count = sizes.copy()
        self.floors = np.minimum(sizes, min_ring)
        self.n_alive = int(self.X.shape[0])

    def area(self, i: int) -> float:
        a, b, c = self.X[self.prv[i]], self.X[i], self.X[self.nxt[i]]
        return 0.5 * abs(float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])))

    def drain(self, heap: list[tuple[float, int]], budget: int) -> set[int]:
        """Remove the least-area vertices until the budget is met or the heap is empty; the blocked ones."""
        blocked: set[int] = set()
        while heap and self.n_alive > budget:
            a, i = heapq.heappop(heap)
            if not self.alive[i] or a != self.area(i):
                continue  # stale entry
            r = self.ring_of[i]
            if self.count[r] <= self.floors[r]:
                continue
            if not _removable(i, self.X, self.alive, self.nxt, self.prv, self.interior):
                blocked.add(i)
                continue
            p, q = self.prv[i], self.nxt[i]
            self.alive[i] = False
            self.nxt[p], self.prv[q] = q, p
            self.count[r] -= 1
            self.n_alive -= 1
            for j in (int(p), int(q)):
                blocked.discard(j)
                if not self.protected[j]:
                    heapq.heappush(heap, (self.area(j), j))
        return blocked


def _removable(
    i: int, X: FloatArray, alive: BoolArray, nxt: IntArray, prv: IntArray, interior: FloatArray
) -> bool:
    """Whether removing vertex ``i`` keeps every ring simple and every point on its side."""
    p, q = prv[i], nxt[i]
    a, b, c = X[p], X[i], X[q]
    lo = np.minimum(np.minimum(a, b), c)
    hi = np.maximum(np.maximum(a, b), c)
    T = X[nxt]
    near = alive & np.all((np.maximum(X, T) >= lo) & (np.minimum(X, T) <= hi), axis=1)
    near[[p, i, q]] = False
    idx = np.flatnonzero(near)
    if _cross2(a, b, c[None, :])[0] != 0:  # a degenerate triangle contains nothing new
        inside = np.all((X[idx] >= lo) & (X[idx] <= hi), axis=1)
        pts = np.vstack([X[idx[inside]], interior])
        if pts.shape[0] and np.any(_in_triangle(pts, a, b, c)):
            return False
    # edges s -> nxt[s] near the triangle, not touching the new edge's endpoints
    s = idx[nxt[idx] != p]
    return not np.any(_segments_cross(a, c, X[s], T[s]))


def _cross2(o: FloatArray, u: FloatArray, v: FloatArray) -> FloatArray:
    return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (
        v[..., 0] - o[..., 0]
    )


def _in_triangle(P: FloatArray, a: FloatArray, b: FloatArray, c: FloatArray) -> BoolArray:
    """Points of ``P`` (m, 2) inside or on triangle abc (either orientation)."""
    d1, d2, d3 = _cross2(a, b, P), _cross2(b, c, P), _cross2(c, a, P)
    neg = (d1 < 0) | (d2 < 0) | (d3 < 0)
    pos = (d1 > 0) | (d2 > 0) | (d3 > 0)
    return ~(neg & pos)


def _segments_cross(a: FloatArray, c: FloatArray, S: FloatArray, T: FloatArray) -> BoolArray:
    """Whether segment ac meets each segment S[k] T[k] (touching counts)."""
    d1 = _cross2(a, c, S)
    d2 = _cross2(a, c, T)
    d3 = _cross2(S, T, a[None, :])
    d4 = _cross2(S, T, c[None, :])
    return (
        (d1 * d2 <= 0) & (d3 * d4 <= 0) & ~((d1 == 0) & (d2 == 0) & _disjoint_collinear(a, c, S, T))
    )


def _disjoint_collinear(a: FloatArray, c: FloatArray, S: FloatArray, T: FloatArray) -> BoolArray:
    """For collinear segments: whether their projections on ac do not overlap."""
    d = c - a
    ta = 0.0
    tc = float(d @ d)
    ts = (S - a) @ d
    tt = (T - a) @ d
    return (np.maximum(ts, tt) < ta) | (np.minimum(ts, tt) > tc)
