"""Consistent boundaries: corresponding points on two polylines keeping the vertices of both."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .boundary_anchors import _ring_arc
from .hole_cuts import HoleCuts
from .shape_rings import ShapeRings


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


@dataclass(frozen=True)
class ConsistentBoundary:
    """The disk patch's boundary in both shapes, point for point.

    The boundary runs along the outer arcs between corners; at a hole's corner
    it goes down the cut, once round the hole and back up the cut. Entries that
    are the same vertex of the shape (the cut's two sides, the hole's start)
    share a vertex id.

    Attributes
    ----------
    Bs, Bt : (nb, 2) float64
        The boundary entries in the source and the target.
    uid : (nb,) int64
        Vertex id of each entry: outer-ring vertices first (0 … n_outer−1), then
        hole-ring vertices, then the cuts' inner points.
    n_u : int
        Number of distinct vertex ids.
    n_outer, n_hole : int
        Vertices on the outer rings and on the hole rings.
    copies : dict of int to list of int
        The entries of each vertex id.
    cut_edges : set of (int, int)
        Edges (vertex ids, sorted) along the cuts.
    segs : (s, 2) int64
        Constraint segments (vertex ids) of the patch triangulations.
    anchor_pos : (b,) int64
        Entry of each boundary anchor (in source order).
    """

    Bs: FloatArray
    Bt: FloatArray
    uid: IntArray
    n_u: int
    n_outer: int
    n_hole: int
    copies: dict[int, list[int]]
    cut_edges: set[tuple[int, int]]
    segs: IntArray
    anchor_pos: IntArray

    @property
    def nb(self) -> int:
        """Number of boundary entries."""
        return int(self.Bs.shape[0])


def consistent_boundaries(
    source: ShapeRings, target: ShapeRings, cuts: HoleCuts, spacing: tuple[float, float]
) -> ConsistentBoundary:
    """Corresponding boundary points of the two disk patches, keeping every vertex of both shapes.

    Each outer arc between corners, each cut and each hole ring is sampled by
    :func:`_consistent_arc` (the vertices of both shapes kept, pieces split
    equally, at most ``spacing`` long).

    Parameters
    ----------
    source, target : ShapeRings
    cuts : HoleCuts
        Holes' pairing, cuts and the disk's corners.
    spacing : (float, float)
        Longest boundary piece in the source and in the target.

    Returns
    -------
    ConsistentBoundary
    """
    h_s, h_t = spacing
    hole_match = cuts.hole_match
    corners = cuts.corners
    Bs_l: list[FloatArray] = []
    Bt_l: list[FloatArray] = []
    keys: list[tuple] = []
    cut_pts: dict[int, tuple[FloatArray, FloatArray]] = {}
    for h, ((ps, qs, _), (pt, qt, _)) in enumerate(cuts.cuts):
        hole_s, hole_t = source.holes[h], target.holes[hole_match[h]]
        cut_pts[h] = _consistent_arc(
            np.array([source.outer[ps], hole_s[qs]]),
            np.array([target.outer[pt], hole_t[qt]]),
            h_s,
            h_t,
        )
    anchor_pos = np.zeros(sum(1 for c in corners if c[0] == "a"), dtype=np.int64)
    K = len(corners)
    for c in range(K):
        kind, idx, s0, t0 = corners[c]
        _, _, s1, t1 = corners[(c + 1) % K]
        if kind == "c":
            h = idx
            (ps, qs, _), (pt, qt, _) = cuts.cuts[h]
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
    return ConsistentBoundary(
        Bs, Bt, uid, n_u, n_outer, n_hole, copies, cut_edges, segs, anchor_pos
    )
