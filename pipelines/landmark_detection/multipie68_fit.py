"""Fitting the 478 → 68 table on annotated faces (used by ``scripts/calibrate_landmarks.py``).

For each Multi-PIE landmark the ``k`` FaceMesh points nearest to it on average
(over the calibration faces, in image space, distances in units of each face's
outer-eye-corner distance) are combined with weights ``w`` summing to 1, fitted
by least squares with a ridge towards the single nearest point::

    min_w  sum_f |P_f w - t_f|^2 + lam |w - e_1|^2   subject to   1^T w = 1

where ``P_f`` (2, k) holds the chosen FaceMesh points of face ``f`` and ``t_f``
(2,) the landmark's projection, both divided by that face's eye distance. The
constraint makes the mapping independent of where the face sits in the image,
and the normalisation independent of its size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.landmark_detection.mediapipe_detector import (
    LEFT_EYE_OUTER,
    RIGHT_EYE_OUTER,
)
from conformorph.pipelines.landmark_detection.multipie68 import Multipie68Table


@dataclass(frozen=True)
class TableFitOptions:
    """Options of :func:`fit_multipie68_table`.

    Attributes
    ----------
    points_per_landmark : int
        FaceMesh points combined per landmark, ``k`` (default 6).
    ridge : float
        ``lam``, the pull towards the nearest point, in squared eye distances per face
        (default 0.01).
    """

    points_per_landmark: int = 6
    ridge: float = 0.01


def affine_weights(
    P: NDArray[np.float64], t: NDArray[np.float64], w0: NDArray[np.float64], ridge: float
) -> NDArray[np.float64]:
    """Least-squares weights summing to 1 with a ridge towards ``w0``.

    Parameters
    ----------
    P : (N, k) float64
        Stacked coordinates of the k candidate points (one row per face and axis).
    t : (N,) float64
        The target coordinates.
    w0 : (k,) float64
        Prior weights (summing to 1).
    ridge : float
        ``lam`` ≥ 0.

    Returns
    -------
    (k,) float64
        ``argmin |P w - t|^2 + lam |w - w0|^2`` subject to ``sum(w) = 1`` (solved on the
        constraint's null space, so the sum is exact).
    """
    k = P.shape[1]
    if k == 1:
        return np.ones(1)
    # w = w0 + N z with the columns of N (e_j - e_0) summing to zero: the constraint holds exactly
    N = np.vstack([-np.ones((1, k - 1)), np.eye(k - 1)])
    PN = P @ N
    z = np.linalg.solve(PN.T @ PN + ridge * (N.T @ N), PN.T @ (t - P @ w0))
    return w0 + N @ z


def eye_distance(facemesh: NDArray[np.float64]) -> float:
    """Outer-eye-corner distance of FaceMesh points (478, 2), in pixels."""
    return float(np.linalg.norm(facemesh[LEFT_EYE_OUTER] - facemesh[RIGHT_EYE_OUTER]))


def fit_multipie68_table(
    facemesh: list[NDArray[np.float64]], targets: list[NDArray[np.float64]],
    options: TableFitOptions | None = None, meta: dict[str, Any] | None = None,
) -> Multipie68Table:
    """Fit the table on calibration faces.

    Parameters
    ----------
    facemesh : list of (478, 2) float64
        FaceMesh points of each calibration face (pixels).
    targets : list of (68, 2) float64
        The annotated landmarks projected into the same images.
    options : TableFitOptions, optional
    meta : dict, optional
        Stored with the table.

    Returns
    -------
    Multipie68Table
    """
    options = options or TableFitOptions()
    scale = [eye_distance(p) for p in facemesh]
    Ps = np.stack([p / s for p, s in zip(facemesh, scale, strict=True)])  # (f, 478, 2)
    Ts = np.stack([t / s for t, s in zip(targets, scale, strict=True)])  # (f, 68, 2)
    k = options.points_per_landmark
    index = np.zeros((Ts.shape[1], k), dtype=np.int64)
    weight = np.zeros((Ts.shape[1], k))
    for lm in range(Ts.shape[1]):
        dist = np.linalg.norm(Ps - Ts[:, lm : lm + 1], axis=2).mean(axis=0)  # (478,)
        idx = np.argsort(dist, kind="stable")[:k]
        P = Ps[:, idx].transpose(0, 2, 1).reshape(-1, k)  # (2f, k)
        w0 = np.zeros(k)
        w0[0] = 1.0
        index[lm] = idx
        weight[lm] = affine_weights(P, Ts[:, lm].reshape(-1), w0, options.ridge * len(facemesh))
    return Multipie68Table(index, weight, dict(meta or {}))
