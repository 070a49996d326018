"""Corresponding boundary points of two outlines, found without anchors.

The two outer rings are put in a normal frame (counter-clockwise, centroid at
the origin, unit area), resampled at ``samples`` equal arc-length steps, and
the rigid part is removed: for every cyclic starting offset of the target
samples the best rotation is the orthogonal Procrustes solution (in complex
numbers ``R = w / |w|`` with ``w = sum conj(z_s) z_t``), and the offsets with
the smallest residual (its local minima) are the candidates. For each
candidate the turning-angle features of the two rings
(:func:`conformorph.geometry.outline_features.outline_features`) are aligned by dynamic
programming in their order along the rings (match, or skip one feature at a
cost of its saliency), and the candidate of least total cost wins. Anchors
the user gives always win: those on the boundary cut both rings into
segments that correspond end to end, and the DP runs inside each segment.

:func:`conformorph.geometry.hole_pairing.pair_holes` pairs the holes of the two shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._typing import ComplexArray, FloatArray, IntArray
from .hole_pairing import ring_centroid_area
from .outline_features import FeatureOptions, OutlineFeatures, outline_features, ring_arc_positions


@dataclass(frozen=True)
class MatchOptions:
    """Options of :func:`match_outlines`.

    Attributes
    ----------
    samples : int
        Arc-length samples per ring for the Procrustes step (default 128).
    candidates : int
        Starting offsets (the Procrustes residual's lowest local minima)
        evaluated by the feature DP (default 6).
    allow_reflection : bool
        Also try the target's mirror image (default False: outlines keep
        their handedness).
    position_weight, arc_weight, turning_weight : float
        Weights of a matched pair's cost: distance of the rotated source
        feature to the target feature (normal frame, unit area; default
        1.0), difference of their arc positions within their segment
        (fractions of the perimeter; default 2.0), and difference of their
        turning angles over pi (default 0.5).
    skip_weight : float
        Cost of leaving a feature unmatched, times its saliency (default 1.0).
    max_pair_cost : float
        Pairs dearer than this are never matched (default 1.5).
    rigid_weight : float
        Weight of the candidate's mean squared Procrustes residual in its
        total cost (default 1.0).
    rotation_weight : float
        Weight of ``1 - cos(rotation)`` in a candidate's total cost (default
        1.0): outlines drawn upright are preferred upright. Set 0 for a
        matching invariant to rotating one ring.
    min_pairs : int
        Fewest pairs returned; missing ones are filled in the largest gaps
        by arc-length correspondence (default 3; the 2D morph needs 2).
    seed_tolerance : float
        A seed anchor closer than this fraction of the ring's diameter to the
        outer ring is a boundary anchor (default 1e-3); others are interior
        anchors, kept but not used to cut the rings.
    features : FeatureOptions
        Options of the feature detector.
    """

    samples: int = 128
    candidates: int = 6
    allow_reflection: bool = False
    position_weight: float = 1.0
    arc_weight: float = 2.0
    turning_weight: float = 0.5
    skip_weight: float = 1.0
    max_pair_cost: float = 1.5
    rigid_weight: float = 1.0
    rotation_weight: float = 1.0
    min_pairs: int = 3
    seed_tolerance: float = 1e-3
    features: FeatureOptions = FeatureOptions()


@dataclass(frozen=True)
class OutlineMatch:
    """Corresponding points of two outer rings, in source-ring order.

    Attributes
    ----------
    source_index, target_index : (k,) int64
        Vertex index on the input source / target ring (-1 for a seed anchor
        that is not at a vertex, or an interior seed).
    source_points, target_points : (k, 2) float64
        The points (a seed anchor's own coordinates; otherwise the vertex).
    origin : tuple of str
        Per pair: ``"seed"`` (given by the user), ``"feature"`` (matched
        features) or ``"fill"`` (arc-length correspondence added to reach
        ``min_pairs``).
    cost : float
        Total cost of the chosen candidate (DP cost plus weighted residual).
    rotation : float
        Rotation (radians) taking the normalised source onto the normalised
        target: the Procrustes rotation of the boundary pairs returned (of
        the chosen arc-length offset when there are fewer than two).
    offset : float
        Target arc position (fraction of its perimeter, from its vertex 0 in
        counter-clockwise order) matched to the source's vertex 0.
    reflected : bool
        Whether the target's mirror image was matched.
    procrustes_rms : float
        RMS distance of the aligned arc-length samples (normal frame, unit
        area).
    """

    source_index: IntArray
    target_index: IntArray
    source_points: FloatArray
    target_points: FloatArray
    origin: tuple[str, ...]
    cost: float
    rotation: float
    offset: float
    reflected: bool
    procrustes_rms: float

    @property
    def anchors(self) -> FloatArray:
        """(k, 2, 2) float64: the pairs as anchors, ``[i, 0]`` source, ``[i, 1]`` target."""
        return np.stack([self.source_points, self.target_points], axis=1)


@dataclass(frozen=True)
class _Ring:
    """A ring in its normal frame: CCW copy ``Q``, index map to the input, features."""

    Q: FloatArray  # (n, 2) counter-clockwise copy (input coordinates)
    index: IntArray  # (n,) Q vertex -> input vertex
    z: ComplexArray  # (n,) normalised vertices
    u: FloatArray  # (n,) arc fractions of Q's vertices
    features: OutlineFeatures


@dataclass(frozen=True)
class _Candidate:
    cost: float
    rotation: complex
    offset: float
    rms: float
    pairs: list[tuple[int, int]]


def match_outlines(
    source_ring: ArrayLike,
    target_ring: ArrayLike,
    *,
    seed_anchors: ArrayLike | None = None,
    options: MatchOptions | None = None,
) -> OutlineMatch:
    """Corresponding boundary points of two outer rings, by cyclic DP over features.

    Parameters
    ----------
    source_ring, target_ring : (n, 2), (m, 2) array_like
        Closed outer rings (either orientation), last point not repeated.
    seed_anchors : (a, 2, 2) array_like, optional
        Anchors the user gives (``[i, 0]`` source, ``[i, 1]`` target); all
        are returned unchanged. Those on the boundary must come in the same
        cyclic order on both rings; they fix the start and the rotation, and
        the automatic matching runs between consecutive ones.
    options : MatchOptions, optional

    Returns
    -------
    OutlineMatch

    Raises
    ------
    ValueError
        A ring not (n, 2) with n >= 3 or of zero area, seed anchors not
        (a, 2, 2), or boundary seed anchors in different cyclic orders on
        the two rings.

    Notes
    -----
    Invariant to translating, rotating and scaling either ring, to its
    starting vertex and to its orientation (the returned indices refer to
    the input rings), up to ties.
    """
    opts = options or MatchOptions()
    src = _normal_ring(source_ring, opts)
    variants = [(_normal_ring(target_ring, opts), False)]
    if opts.allow_reflection:
        mirrored = np.asarray(target_ring, dtype=np.float64) * [-1.0, 1.0]
        variants.append((_normal_ring(mirrored, opts), True))
    seeds = _seed_array(seed_anchors)
    results = []
    for tgt, reflected in variants:
        variant_seeds = seeds.copy()
        if reflected:
            variant_seeds[:, 1, 0] *= -1.0  # the target side lives in the mirrored ring
        on_ring = _boundary_seeds(src, tgt, variant_seeds, opts)
        results.append((_match_candidates(src, tgt, on_ring, opts), tgt, reflected, on_ring))
    cand, tgt, reflected, on_ring = min(results, key=lambda r: r[0].cost)  # first on ties
    return _assemble(src, tgt, source_ring, target_ring, seeds, on_ring, cand, reflected, opts)


def _normal_ring(ring: ArrayLike, opts: MatchOptions) -> _Ring:
    P = np.asarray(ring, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 3 or not np.all(np.isfinite(P)):
        raise ValueError(f"ring must be a finite (n, 2) array with n >= 3, got {P.shape}")
    centroid, area = ring_centroid_area(P)
    c = np.array([centroid.real, centroid.imag])
    index = np.arange(P.shape[0], dtype=np.int64)
    if area < 0:
        index = index[::-1].copy()
    Q = P[index]
    zq = (Q - c) / np.sqrt(abs(area))
    s, perimeter = ring_arc_positions(Q)
    return _Ring(
        Q=Q,
        index=index,
        z=zq[:, 0] + 1j * zq[:, 1],
        u=s / perimeter,
        features=outline_features(Q, options=opts.features),
    )


def _points_at(r: _Ring, arc: FloatArray) -> ComplexArray:
    """Normalised points of ``r`` at arc fractions ``arc`` (any real, mod 1)."""
    q = np.mod(arc, 1.0)
    uc = np.concatenate([r.u, [1.0]])
    zc = np.concatenate([r.z, r.z[:1]])
    return np.interp(q, uc, zc.real) + 1j * np.interp(q, uc, zc.imag)


def _seed_array(seed_anchors: ArrayLike | None) -> FloatArray:
    if seed_anchors is None:
        return np.zeros((0, 2, 2))
    A = np.array(seed_anchors, dtype=np.float64)
    if A.size == 0:
        return np.zeros((0, 2, 2))
    if A.ndim != 3 or A.shape[1:] != (2, 2) or not np.all(np.isfinite(A)):
        raise ValueError(f"seed_anchors must be a finite (a, 2, 2) array, got {A.shape}")
    return A


def _project_arc(Q: FloatArray, p: FloatArray) -> tuple[float, float]:
    """Arc fraction of the point of ring ``Q`` nearest ``p``, and its distance."""
    B = np.roll(Q, -1, axis=0)
    e = B - Q
    t = np.clip(
        np.einsum("ij,ij->i", p - Q, e) / np.maximum(np.einsum("ij,ij->i", e, e), 1e-300), 0, 1
    )
    dist = np.linalg.norm(Q + t[:, None] * e - p, axis=1)
    k = int(np.argmin(dist))
    s, perimeter = ring_arc_positions(Q)
    return float((s[k] + t[k] * np.linalg.norm(e[k])) / perimeter) % 1.0, float(dist[k])


def _boundary_seeds(
    src: _Ring, tgt: _Ring, seeds: FloatArray, opts: MatchOptions
) -> list[tuple[float, float, int]]:
    """(source arc, target arc, seed index) of seeds on both outer rings, in source order."""
    out = []
    ds = np.ptp(src.Q, axis=0).max()
    dt = np.ptp(tgt.Q, axis=0).max()
    for i, (ps, pt) in enumerate(seeds):
        a, da = _project_arc(src.Q, ps)
        b, db = _project_arc(tgt.Q, pt)
        if da <= opts.seed_tolerance * ds and db <= opts.seed_tolerance * dt:
            out.append((a, b, i))
    out.sort()
    if len(out) >= 2:
        tb = np.array([o[1] for o in out])
        winding = np.mod(np.diff(np.concatenate([tb, tb[:1]])), 1.0).sum()
        if not np.isclose(winding, 1.0, atol=1e-9):
            raise ValueError(
                "boundary seed anchors must run in the same cyclic order around both outlines"
            )
    return out


def _procrustes_offsets(
    src: _Ring, tgt: _Ring, opts: MatchOptions
) -> list[tuple[float, complex, float]]:
    """(offset, rotation, mean squared residual) of the best cyclic offsets."""
    N = opts.samples
    grid = np.arange(N) / N
    zs = _points_at(src, grid)
    zt = _points_at(tgt, grid)
    rolled = zt[(np.arange(N)[:, None] + np.arange(N)[None, :]) % N]  # [m, k] = zt[k + m]
    w = rolled @ np.conj(zs)
    resid = (np.sum(np.abs(zs) ** 2) + np.sum(np.abs(zt) ** 2) - 2 * np.abs(w)) / N
    is_min = (resid <= np.roll(resid, 1)) & (resid <= np.roll(resid, -1))
    total = opts.rigid_weight * resid + opts.rotation_weight * (1.0 - np.real(w) / np.abs(w))
    order = [int(m) for m in np.argsort(total) if is_min[m]][: opts.candidates]
    return [(m / N, complex(w[m] / abs(w[m])), float(resid[m])) for m in order]


def _seeded_rotation(
    src: _Ring, tgt: _Ring, on_ring: list[tuple[float, float, int]], N: int
) -> tuple[complex, float]:
    """Procrustes rotation and residual of the piecewise-linear arc map between seeds."""
    a = np.array([o[0] for o in on_ring])
    b = np.array([o[1] for o in on_ring])
    ua = np.concatenate([a, [a[0] + 1.0]])
    ub = b[0] + np.concatenate([[0.0], np.cumsum(np.mod(np.diff(b), 1.0)), [1.0]])
    grid = a[0] + np.arange(N) / N
    zs = _points_at(src, grid)
    zt = _points_at(tgt, np.interp(grid, ua, ub))
    w = complex(np.sum(np.conj(zs) * zt))
    rot = w / abs(w) if abs(w) > 0 else 1.0 + 0j
    return rot, float(np.mean(np.abs(zt - rot * zs) ** 2))


def _segments(
    on_ring: list[tuple[float, float, int]], offset: float, src: _Ring
) -> list[tuple[float, float, float, float]]:
    """(source start, source length, target start, target length) of the matched segments."""
    if not on_ring:
        a = src.features.arc
        if a.size:
            gaps = np.mod(np.diff(np.concatenate([a, a[:1] + 1.0])), 1.0 + 1e-12)
            k = int(np.argmax(gaps))
            cut = float((a[k] + gaps[k] / 2) % 1.0)
        else:
            cut = 0.0
        return [(cut, 1.0, (cut + offset) % 1.0, 1.0)]
    out = []
    for k, (sa, sb, _) in enumerate(on_ring):
        sa2, sb2, _ = on_ring[(k + 1) % len(on_ring)]
        la = float(np.mod(sa2 - sa, 1.0)) or 1.0
        lb = float(np.mod(sb2 - sb, 1.0)) or 1.0
        out.append((sa, la, sb, lb))
    return out


def _match_candidates(
    src: _Ring, tgt: _Ring, on_ring: list[tuple[float, float, int]], opts: MatchOptions
) -> _Candidate:
    if on_ring:
        rot, rms2 = _seeded_rotation(src, tgt, on_ring, opts.samples)
        starts = [(np.mod(on_ring[0][1] - on_ring[0][0], 1.0), rot, rms2)]
    else:
        starts = _procrustes_offsets(src, tgt, opts)
    found = []
    for offset, rot, rms2 in starts:
        pairs: list[tuple[int, int]] = []
        cost = opts.rigid_weight * rms2 + opts.rotation_weight * (1.0 - rot.real)
        for seg in _segments(on_ring, float(offset), src):
            p, c = _align_segment(src, tgt, seg, rot, opts)
            pairs += p
            cost += c
        found.append(_Candidate(cost, rot, float(offset), float(np.sqrt(max(rms2, 0.0))), pairs))
    return min(found, key=lambda c: c.cost)  # the first of equal costs


def _in_segment(
    arc: FloatArray, start: float, length: float, margin: float
) -> tuple[IntArray, FloatArray]:
    """Indices of ``arc`` strictly inside the segment (margin from its ends) and their positions in it."""
    x = np.mod(arc - start, 1.0)
    inside = (x > margin) & (x < length - margin)
    return np.flatnonzero(inside), x[inside] / length


def _align_segment(
    src: _Ring, tgt: _Ring, seg: tuple[float, float, float, float], rot: complex, opts: MatchOptions
) -> tuple[list[tuple[int, int]], float]:
    """Align the features inside one segment by DP; pairs of ring (Q) vertex indices and the cost."""
    a0, la, b0, lb = seg
    fs, ft = src.features, tgt.features
    margin = opts.features.min_separation if la < 1.0 else 0.0
    i_s, xs = _in_segment(fs.arc, a0, la, margin)
    i_t, xt = _in_segment(ft.arc, b0, lb, margin)
    os_, ot = np.argsort(xs), np.argsort(xt)
    i_s, xs, i_t, xt = i_s[os_], xs[os_], i_t[ot], xt[ot]
    zs = rot * src.z[fs.index[i_s]]
    zt = tgt.z[ft.index[i_t]]
    C = (
        opts.position_weight * np.abs(zs[:, None] - zt[None, :])
        + opts.arc_weight * np.abs(xs[:, None] * la - xt[None, :] * la)
        + opts.turning_weight * np.abs(fs.turning[i_s][:, None] - ft.turning[i_t][None, :]) / np.pi
    )
    skip_s = opts.skip_weight * fs.saliency[i_s]
    skip_t = opts.skip_weight * ft.saliency[i_t]
    matched, cost = _dp_align(C, skip_s, skip_t, opts.max_pair_cost)
    pairs = [(int(fs.index[i_s[i]]), int(ft.index[i_t[j]])) for i, j in matched]
    return pairs, cost


def _dp_align(
    C: FloatArray, skip_s: FloatArray, skip_t: FloatArray, max_cost: float
) -> tuple[list[tuple[int, int]], float]:
    """Order-preserving alignment of two sequences (match at C[i, j], or skip at its cost)."""
    p, q = C.shape
    D = np.zeros((p + 1, q + 1))
    D[1:, 0] = np.cumsum(skip_s)
    D[0, 1:] = np.cumsum(skip_t)
    move = np.zeros((p + 1, q + 1), dtype=np.int8)  # 0 match, 1 skip source, 2 skip target
    move[1:, 0] = 1
    move[0, 1:] = 2
    Cm = np.where(C <= max_cost, C, np.inf)
    for i in range(1, p + 1):
        for j in range(1, q + 1):
            options = (
                D[i - 1, j - 1] + Cm[i - 1, j - 1],
                D[i - 1, j] + skip_s[i - 1],
                D[i, j - 1] + skip_t[j - 1],
            )
            k = int(np.argmin(options))
            D[i, j] = options[k]
            move[i, j] = k
    pairs = []
    i, j = p, q
    while i > 0 or j > 0:
        step = int(move[i, j])
        if step == 0:
            pairs.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        elif step == 1:
            i -= 1
        else:
            j -= 1
    return pairs[::-1], float(D[p, q])


def _assemble(
    src: _Ring,
    tgt: _Ring,
    source_ring: ArrayLike,
    target_ring: ArrayLike,
    seeds: FloatArray,
    on_ring: list[tuple[float, float, int]],
    cand: _Candidate,
    reflected: bool,
    opts: MatchOptions,
) -> OutlineMatch:
    """Seeds (given order) first, then matched and filled pairs; indices on the input rings."""
    Ps = np.asarray(source_ring, dtype=np.float64)
    Pt = np.asarray(target_ring, dtype=np.float64)
    auto = [(qi, qj, "feature") for qi, qj in cand.pairs]
    # boundary pairs as (source arc, target arc) for the gap filling
    arcs = [(a, b) for a, b, _ in on_ring] + [(src.u[qi], tgt.u[qj]) for qi, qj, _ in auto]
    used_s = {qi for qi, _, _ in auto} | {int(np.argmin(np.abs(src.u - a))) for a, _, _ in on_ring}
    used_t = {qj for _, qj, _ in auto} | {int(np.argmin(np.abs(tgt.u - b))) for _, b, _ in on_ring}
    while len(arcs) + len(seeds) - len(on_ring) < opts.min_pairs and len(used_s) < len(src.u):
        a, b = _gap_middle(sorted(arcs), cand.offset)
        qi = _nearest_free(src.u, a, used_s)
        qj = _nearest_free(tgt.u, b, used_t)
        if qi < 0 or qj < 0:
            break
        used_s.add(qi)
        used_t.add(qj)
        auto.append((qi, qj, "fill"))
        arcs.append((src.u[qi], tgt.u[qj]))
    auto = _reference_first(auto, src, bool(len(seeds)))
    s_idx = [_seed_vertex(Ps, p) for p in seeds[:, 0]]
    t_idx = [_seed_vertex(Pt, p) for p in seeds[:, 1]]
    s_idx += [int(src.index[qi]) for qi, _, _ in auto]
    t_idx += [int(tgt.index[qj]) for _, qj, _ in auto]
    s_pts = [*seeds[:, 0], *(Ps[src.index[qi]] for qi, _, _ in auto)]
    t_pts = [*seeds[:, 1], *(Pt[tgt.index[qj]] for _, qj, _ in auto)]
    rotation = _refined_rotation(src, tgt, on_ring, auto, cand.rotation)
    return OutlineMatch(
        source_index=np.array(s_idx, dtype=np.int64),
        target_index=np.array(t_idx, dtype=np.int64),
        source_points=np.array(s_pts, dtype=np.float64).reshape(-1, 2),
        target_points=np.array(t_pts, dtype=np.float64).reshape(-1, 2),
        origin=("seed",) * len(seeds) + tuple(o for _, _, o in auto),
        cost=float(cand.cost),
        rotation=-rotation if reflected else rotation,
        offset=float(cand.offset),
        reflected=reflected,
        procrustes_rms=float(cand.rms),
    )


def _refined_rotation(
    src: _Ring,
    tgt: _Ring,
    on_ring: list[tuple[float, float, int]],
    auto: list[tuple[int, int, str]],
    fallback: complex,
) -> float:
    """Procrustes rotation of the matched boundary pairs (normal frame); ``fallback`` if under 2."""
    zs = [src.z[qi] for qi, _, _ in auto]
    zt = [tgt.z[qj] for _, qj, _ in auto]
    if on_ring:
        zs += list(_points_at(src, np.array([a for a, _, _ in on_ring])))
        zt += list(_points_at(tgt, np.array([b for _, b, _ in on_ring])))
    w = complex(np.sum(np.conj(np.array(zs)) * np.array(zt))) if len(zs) >= 2 else 0j
    return float(np.angle(w if abs(w) > 0 else fallback))


def _gap_middle(arcs: list[tuple[float, float]], offset: float) -> tuple[float, float]:
    """Middle of the largest source gap between boundary pairs, and its linear target position."""
    if not arcs:
        return 0.0, offset % 1.0
    a = np.array([x for x, _ in arcs])
    b = np.array([y for _, y in arcs])
    ga = np.mod(np.roll(a, -1) - a, 1.0)
    gb = np.mod(np.roll(b, -1) - b, 1.0)
    if len(arcs) == 1:
        ga[:], gb[:] = 1.0, 1.0
    k = int(np.argmax(ga))
    return float((a[k] + ga[k] / 2) % 1.0), float((b[k] + gb[k] / 2) % 1.0)


def _nearest_free(u: FloatArray, arc: float, used: set[int]) -> int:
    d = np.abs(u - arc)
    d = np.minimum(d, 1.0 - d)
    for k in np.argsort(d):
        if int(k) not in used:
            return int(k)
    return -1


def _reference_first(
    auto: list[tuple[int, int, str]], src: _Ring, seeded: bool
) -> list[tuple[int, int, str]]:
    """Source-ring order; without seeds the two pairs farthest apart go first (the reference A, B)."""
    auto = sorted(auto, key=lambda p: src.u[p[0]])
    if seeded or len(auto) < 2:
        return auto
    z = src.z[[p[0] for p in auto]]
    i, j = np.unravel_index(int(np.argmax(np.abs(z[:, None] - z[None, :]))), (len(z), len(z)))
    first = [auto[int(i)], auto[int(j)]]
    return first + [p for k, p in enumerate(auto) if k not in (i, j)]


def _seed_vertex(P: FloatArray, p: FloatArray) -> int:
    """Index of the vertex of ``P`` at ``p`` (within round-off of the ring's size), else -1."""
    d = np.linalg.norm(P - p, axis=1)
    k = int(np.argmin(d))
    return k if d[k] <= 1e-9 * max(float(np.ptp(P, axis=0).max()), 1e-300) else -1
