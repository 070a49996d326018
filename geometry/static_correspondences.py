"""Extra correspondences where two aligned surfaces coincide (the parts that do not move).

Landmarks constrain the disk registration only at m points; between them the
thin-plate map interpolates, and where the conformal factor is large (deep,
narrow parts such as nostrils, which the disk map squeezes into a small area)
a small disk error is a large surface error. Where the two rigidly aligned
surfaces coincide — the parts an expression does not move — the true
correspondence is the closest point, so closest points there are safe extra
landmarks. A sample is accepted when its closest point on the target is
within ``tol`` and agrees, on the target disk, with the position the current
registration predicts to within ``max_disk_offset`` (so moving parts, where
the closest point slides, are rejected).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray
from .surface_distance import SurfaceDistance


@dataclass(frozen=True)
class StaticCorrespondences:
    """Result of :func:`static_correspondences`.

    Attributes
    ----------
    source_uv : (q, 2) float64
        Accepted sample positions on the source disk.
    target_uv : (q, 2) float64
        Their closest points' positions on the target disk.
    accepted : (k,) bool
        Which samples were accepted.
    distance : (k,) float64
        3D distance of every sample to the target surface.
    """

    source_uv: FloatArray
    target_uv: FloatArray
    accepted: BoolArray
    distance: FloatArray


def farthest_point_samples(
    X: FloatArray, k: int, *, candidates: IntArray | None = None
) -> IntArray:
    """Greedy farthest-point sampling of ``k`` indices (deterministic: starts at the first candidate).

    Parameters
    ----------
    X : (n, d) float64
    k : int
    candidates : (c,) int64, optional
        Indices allowed (default all).

    Returns
    -------
    (min(k, c),) int64
    """
    cand = np.arange(X.shape[0]) if candidates is None else np.asarray(candidates, dtype=np.int64)
    if cand.size == 0 or k <= 0:
        return np.zeros(0, dtype=np.int64)
    # squared distances, one contiguous coordinate column at a time, into reused
    # buffers: the same argmax as distances, without a (c, d) temporary per sample
    cols = [np.ascontiguousarray(X[cand, c], dtype=np.float64) for c in range(X.shape[1])]
    n_pick = min(k, cand.size)
    d2 = np.full(cand.size, np.inf)  # squared distance of every candidate to the chosen
    step = np.zeros(cand.size)
    tmp = np.zeros(cand.size)
    chosen = [0]
    while True:
        j = chosen[-1]
        step.fill(0.0)
        for col in cols:
            np.subtract(col, col[j], out=tmp)
            step += np.multiply(tmp, tmp, out=tmp)
        np.minimum(d2, step, out=d2)
        if len(chosen) == n_pick:
            break
        chosen.append(int(np.argmax(d2)))
    return cand[np.asarray(chosen, dtype=np.int64)]


@dataclass(frozen=True)
class StaticCorrespondenceOptions:
    """Acceptance thresholds of :func:`static_correspondences`.

    Attributes
    ----------
    tol : float
        Largest 3D distance of an accepted sample to the target surface (required).
    max_disk_offset : float
        Largest disk distance between the closest point and the prediction (required).
    min_separation : float
        Smallest disk distance between accepted samples, and to the points
        ``keep_away_source`` / ``keep_away_target`` (e.g. the landmarks), on
        the source and on the target disk; samples are taken greedily in order.
        Default 0.
    """

    tol: float
    max_disk_offset: float
    min_separation: float = 0.0


def static_correspondences(
    sample_uv: FloatArray,
    sample_X: FloatArray,
    predicted_uv: FloatArray,
    target_X: FloatArray,
    target_F: IntArray,
    target_uv: FloatArray,
    options: StaticCorrespondenceOptions,
    *,
    keep_away_source: FloatArray | None = None,
    keep_away_target: FloatArray | None = None,
    target_distance: SurfaceDistance | None = None,
) -> StaticCorrespondences:
    """Closest-point correspondences on the parts of two aligned surfaces that coincide.

    Parameters
    ----------
    sample_uv : (k, 2) float64
        Sample points on the source disk.
    sample_X : (k, 3) float64
        The same points on the source surface (aligned to the target).
    predicted_uv : (k, 2) float64
        Where the current registration sends the samples on the target disk.
    target_X : (n, 3) float64
        Target surface (aligned).
    target_F : (m, 3) int64
    target_uv : (n, 2) float64
        Target disk map.
    options : StaticCorrespondenceOptions
        Distance tolerance, disk consistency bound, minimum separation.
    keep_away_source, keep_away_target : (r, 2) float64, optional
        Points accepted samples keep ``min_separation`` from, on each disk.
    target_distance : SurfaceDistance, optional
        Prepared closest-point structure of the target, reused if given.

    Returns
    -------
    StaticCorrespondences
    """
    tol, max_disk_offset = options.tol, options.max_disk_offset
    min_separation = options.min_separation
    ps = np.asarray(sample_uv, dtype=np.float64)
    xs = np.asarray(sample_X, dtype=np.float64)
    zs = np.asarray(predicted_uv, dtype=np.float64)
    if ps.shape != zs.shape or ps.shape[0] != xs.shape[0]:
        raise ValueError("sample_uv, sample_X and predicted_uv must describe the same samples")
    if tol <= 0 or max_disk_offset <= 0:
        raise ValueError("tol and max_disk_offset must be positive")
    F = np.asarray(target_F, dtype=np.int64)
    sd = target_distance or SurfaceDistance(target_X, F)
    cp, d, tri = sd.closest_triangles(xs, k=8)
    c = np.asarray(target_X, dtype=np.float64)[F[tri]]  # (k, 3, 3)
    # barycentrics of the closest point in its triangle
    e0, e1, r = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0], cp - c[:, 0]
    d00 = np.einsum("ij,ij->i", e0, e0)
    d01 = np.einsum("ij,ij->i", e0, e1)
    d11 = np.einsum("ij,ij->i", e1, e1)
    d20 = np.einsum("ij,ij->i", r, e0)
    d21 = np.einsum("ij,ij->i", r, e1)
    den = np.where(d00 * d11 - d01**2 != 0, d00 * d11 - d01**2, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    bary = np.clip(np.stack([1 - v - w, v, w], axis=1), 0.0, 1.0)
    bary /= bary.sum(axis=1, keepdims=True)
    q = np.einsum("kj,kjd->kd", bary, np.asarray(target_uv, dtype=np.float64)[F[tri]])
    ok = (d <= tol) & (np.linalg.norm(q - zs, axis=1) <= max_disk_offset)
    if min_separation > 0:
        # keep accepted samples apart on both disks (and away from ``keep_away``): two
        # nearly coincident constraints with slightly different targets make the thin
        # plate interpolant wild
        none = np.zeros((0, 2))
        ks = none if keep_away_source is None else keep_away_source
        kt = none if keep_away_target is None else keep_away_target
        taken_p = [np.asarray(ks, dtype=np.float64).reshape(-1, 2)]
        taken_q = [np.asarray(kt, dtype=np.float64).reshape(-1, 2)]
        for j in np.flatnonzero(ok):
            Pp = np.vstack(taken_p)
            Qq = np.vstack(taken_q)
            if (Pp.size and np.min(np.linalg.norm(Pp - ps[j], axis=1)) < min_separation) or (
                Qq.size and np.min(np.linalg.norm(Qq - q[j], axis=1)) < min_separation
            ):
                ok[j] = False
                continue
            taken_p.append(ps[j][None])
            taken_q.append(q[j][None])
    return StaticCorrespondences(ps[ok], q[ok], ok, d)
