"""Hole cuts: one straight cut per pair of holes from the hole to the outer ring, between the same anchors."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .boundary_anchors import _ring_params
from .shape_rings import HoleCorrespondenceError, ShapeRings, _segments_cross, points_in_shape


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


def _check_cuts_apart(
    shape: ShapeRings, cuts: list[tuple[int, int, float]], holes: list[int]
) -> None:
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


#: A corner of the disk patch on the outer ring: ("a", boundary anchor j) or
#: ("c", hole h), with its source and target arc-length parameters.
Corner = tuple[str, int, float, float]


@dataclass(frozen=True)
class HoleCuts:
    """The straight cuts that open a shape with holes into a disk, and the disk's corners.

    Attributes
    ----------
    hole_match : list of int
        Target hole of each source hole.
    cuts : list of ((int, int, float), (int, int, float))
        Per source hole h, ``((p_s, q_s, s_s), (p_t, q_t, s_t))``: outer vertex
        p, hole vertex q and the arc-length parameter of p, in source and target.
    corners : list of (str, int, float, float)
        Boundary anchors and cut ends on the outer ring, in source order from the
        first boundary anchor.
    """

    hole_match: list[int]
    cuts: list[tuple[tuple[int, int, float], tuple[int, int, float]]]
    corners: list[Corner]


def hole_cuts(
    source: ShapeRings,
    target: ShapeRings,
    s_par: FloatArray,
    t_par: FloatArray,
    hole_match: Sequence[int] | None = None,
) -> HoleCuts:
    """Pair the holes and cut each pair to the outer rings between the same boundary anchors.

    Parameters
    ----------
    source, target : ShapeRings
        Equally many holes.
    s_par, t_par : (b,) float64
        Arc-length parameters of the boundary anchors, sorted in source order
        (:func:`conformorph.geometry.boundary_anchors.boundary_anchors`).
    hole_match : sequence of int, optional
        Target hole of each source hole; default the pairing nearest in
        bounding-box coordinates.

    Returns
    -------
    HoleCuts

    Raises
    ------
    ValueError
        ``hole_match`` not a permutation.
    HoleCorrespondenceError
        Cuts that meet, or reach the outer rings in different orders.
    """
    if hole_match is not None:
        match = [int(h) for h in hole_match]
        if sorted(match) != list(range(len(target.holes))):
            raise ValueError(
                f"hole_match must be a permutation of 0..{len(target.holes) - 1}, got {match}"
            )
    else:
        match = _match_holes(source, target) if source.holes else []
    cuts = _choose_cuts(source, target, s_par, t_par, match) if source.holes else []
    _check_cuts_apart(source, [c[0] for c in cuts], list(range(len(cuts))))
    _check_cuts_apart(target, [c[1] for c in cuts], match)
    # corners on the outer ring, in source order from the first anchor: ("a", i) or ("c", hole)
    corners: list[Corner] = [("a", j, float(s_par[j]), float(t_par[j])) for j in range(s_par.size)]
    corners += [("c", h, c[0][2], c[1][2]) for h, c in enumerate(cuts)]
    Ls, Lt = _ring_params(source.outer)[1], _ring_params(target.outer)[1]
    corners.sort(key=lambda c: (c[2] - s_par[0]) % Ls)
    t_rel = np.array([(c[3] - t_par[0]) % Lt for c in corners])
    if np.any(np.diff(t_rel) <= 0):
        raise HoleCorrespondenceError(
            "the holes' cuts reach the outer boundaries in different orders; add boundary anchors"
        )
    return HoleCuts(match, cuts, corners)


def check_hole_counts(source: ShapeRings, target: ShapeRings) -> None:
    """Raise HoleCorrespondenceError unless both shapes have equally many holes.

    Parameters
    ----------
    source, target : ShapeRings

    Raises
    ------
    HoleCorrespondenceError
    """
    if len(source.holes) != len(target.holes):
        raise HoleCorrespondenceError(
            f"the source has {len(source.holes)} hole(s) and the target {len(target.holes)}: "
            "holes cannot correspond (a patch dissection needs equally many holes)"
        )
