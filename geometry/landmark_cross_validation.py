"""Leave-k-out cross-validation of a landmark registration on the disk.

Table 2 of the face morphing paper compares MT and DMT by E_D (eq. 2) and E
(eq. 3) *at the landmarks the maps were fitted to*. With its centres at the
landmarks and ε = 0, the thin-plate part of DMT interpolates them, so there
DMT's E_D and E are 0 by construction and say nothing about the map between
landmarks. The honest measure of a registration is its error at landmarks it
did not see: split the m landmarks into ``folds`` groups, fit the map to all
groups but one, map the held-out group and measure its distance to its true
targets, for every group in turn (k-fold cross-validation; ``folds = m`` is
leave-one-out). Every landmark then gets exactly one held-out image, and the
paper's sums (2) and (3) are taken over those images.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ._typing import FloatArray, IntArray
from .disk_registration import register_disk_landmarks
from .landmark_pairs import validate_landmark_pairs
from .registration_error import disk_registration_error


@dataclass(frozen=True)
class CrossValidation:
    """Result of :func:`cross_validate_registration`.

    Attributes
    ----------
    method : str
        ``"mt"`` or ``"dmt"``.
    folds : (m,) int64
        The fold of every landmark (0 … k − 1).
    held_out_uv : (m, 2) float64
        Each landmark's image under the map fitted without its fold.
    fitted_uv : (m, 2) float64
        The images under the map fitted to all landmarks.
    E_D_held_out : float
        Eq. (2) over the held-out images.
    E_D_fitted : float
        Eq. (2) of the map fitted to all landmarks.
    folded_triangles : list of int
        Folded triangles of the check mesh under each fold's map.
    folded_triangles_fitted : int
        Same for the map fitted to all landmarks.
    fallbacks : list of str or None
        Each fold's DMT fallback (see :mod:`conformorph.geometry.disk_registration`).
    """

    method: str
    folds: IntArray
    held_out_uv: FloatArray
    fitted_uv: FloatArray
    E_D_held_out: float
    E_D_fitted: float
    folded_triangles: list[int]
    folded_triangles_fitted: int
    fallbacks: list[str | None]


def landmark_folds(m: int, k: int, *, seed: int = 0) -> IntArray:
    """Assign m landmarks to k folds of (nearly) equal size, at random but reproducibly.

    Parameters
    ----------
    m : int
        Landmarks.
    k : int
        Folds, 2 ≤ k ≤ m.
    seed : int, default 0

    Returns
    -------
    (m,) int64
        Fold of each landmark; fold sizes differ by at most one.

    Examples
    --------
    >>> f = landmark_folds(7, 3)
    >>> sorted(np.bincount(f).tolist())
    [2, 2, 3]
    """
    if not 2 <= k <= m:
        raise ValueError(f"need 2 ≤ folds ≤ landmarks, got {k} folds for {m} landmarks")
    perm = np.random.default_rng(seed).permutation(m)
    out = np.zeros(m, dtype=np.int64)
    out[perm] = np.arange(m) % k
    return out


def cross_validate_registration(
    source_uv: FloatArray,
    target_uv: FloatArray,
    check_uv: FloatArray,
    check_F: IntArray,
    *,
    method: Literal["mt", "dmt"],
    folds: int = 10,
    seed: int = 0,
    kernel_scale: FloatArray | None = None,
    min_fit: int = 3,
) -> CrossValidation:
    """k-fold cross-validation of an MT or DMT landmark registration.

    Parameters
    ----------
    source_uv : (m, 2) float64
        Landmarks P on the source disk.
    target_uv : (m, 2) float64
        Landmarks Q on the target disk.
    check_uv : (n, 2) float64
        Nodes of a counter-clockwise triangulation of the source disk, on which
        every fitted map is checked for folds.
    check_F : (k, 3) int64
    method : {"mt", "dmt"}
    folds : int, default 10
        Number of folds (``m`` = leave-one-out).
    seed : int, default 0
        Seed of the fold assignment (:func:`landmark_folds`).
    kernel_scale : (m,) float64, optional
        :math:`\\lambda_1^2/\\lambda_0^2` at each landmark (subset with the fold).
    min_fit : int, default 3
        Fewest landmarks a fold's fit may use.

    Returns
    -------
    CrossValidation

    Raises
    ------
    ValueError
        On bad landmark sets, a bad fold count, or folds leaving fewer than
        ``min_fit`` landmarks to fit.
    """
    P, Q = validate_landmark_pairs(source_uv, target_uv, min_count=3, fit="a registration")
    m = P.shape[0]
    s = None if kernel_scale is None else np.asarray(kernel_scale, dtype=np.float64)
    if s is not None and s.shape != (m,):
        raise ValueError(f"kernel_scale must be ({m},), got {s.shape}")
    assign = landmark_folds(m, folds, seed=seed)
    if m - int(np.bincount(assign).max()) < min_fit:
        raise ValueError(f"{folds} folds leave fewer than {min_fit} of {m} landmarks to fit")

    def fit(keep: IntArray) -> tuple[Callable[[FloatArray], FloatArray], int, str | None]:
        reg = register_disk_landmarks(
            P[keep],
            Q[keep],
            check_uv,
            check_F,
            method=method,
            kernel_scale=None if s is None else s[keep],
        )
        n_folded = -1 if reg.fold is None else int(reg.fold.n_folded)
        return reg.apply, n_folded, reg.fallback

    held = np.zeros_like(P)
    folded: list[int] = []
    fallbacks: list[str | None] = []
    for j in range(folds):
        out = assign == j
        apply, n_folded, fb = fit(np.flatnonzero(~out))
        held[out] = apply(P[out])
        folded.append(n_folded)
        fallbacks.append(fb)
    apply_all, folded_all, _ = fit(np.arange(m))
    fitted = apply_all(P)
    return CrossValidation(
        method=method,
        folds=assign,
        held_out_uv=held,
        fitted_uv=fitted,
        E_D_held_out=disk_registration_error(held, Q),
        E_D_fitted=disk_registration_error(fitted, Q),
        folded_triangles=folded,
        folded_triangles_fitted=folded_all,
        fallbacks=fallbacks,
    )
