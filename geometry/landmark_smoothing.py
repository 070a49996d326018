"""How much a thin-plate landmark fit should smooth, from the landmarks' noise.

An extension of the face morphing paper, whose DMT interpolates its landmarks
exactly: when the landmarks are imprecise (detected, or placed by hand with a
few millimetres' error), interpolating them bends the map to follow the noise.
The smoothing thin-plate spline of
:func:`conformorph.geometry.thin_plate_registration.thin_plate_registration` approximates
them instead, landmark i with smoothing :math:`\\Lambda_i`. Here
:math:`\\Lambda_i = \\kappa \\sigma_i^2` (a less certain landmark is followed less
closely) and the one scale κ is chosen by Morozov's discrepancy principle: the
fit's residuals should be as large as the noise, no larger,

.. math::

    \\frac{1}{m} \\sum_i \\frac{|f_\\kappa(p_i) - q_i|^2}{\\sigma_i^2} = d\\,\\chi,

with d = 2 the dimension of the disk and χ the target ratio (default 1). The
residual grows monotonically with κ (from 0, the interpolation, to the affine
least-squares fit as κ → ∞); κ is found by bisection on log κ. When even the
affine fit leaves less than the noise, the largest κ tried is returned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray
from .thin_plate_registration import thin_plate_registration

#: Range of κ searched (log-uniform bisection) and the bisection steps.
KAPPA_RANGE = (1e-10, 1e6)
BISECTION_STEPS = 48


@dataclass(frozen=True)
class LandmarkSmoothing:
    """The smoothing chosen by :func:`discrepancy_smoothing`.

    Attributes
    ----------
    smoothing : (m,) float64
        Λ_i = κ σ_i², for :func:`~conformorph.geometry.thin_plate_registration.thin_plate_registration`.
    kappa : float
        The scale κ (0 when every σ_i is 0: interpolation).
    chi : float
        The reached mean of |residual|² / (d σ²) over the landmarks with σ_i > 0.
    saturated : bool
        Even the largest κ left residuals below the noise (the affine fit already
        explains the landmarks within their noise).
    """

    smoothing: FloatArray
    kappa: float
    chi: float
    saturated: bool


def _chi(
    P: FloatArray,
    Q: FloatArray,
    sigma: FloatArray,
    kappa: float,
    kernel_scale: FloatArray | None,
    boundary_taper: bool,
) -> float:
    """Mean |f_κ(p_i) − q_i|² / (2 σ_i²) over the landmarks with σ_i > 0."""
    d, _ = thin_plate_registration(
        P, Q, kernel_scale=kernel_scale, smoothing=kappa * sigma**2, boundary_taper=boundary_taper
    )
    r2 = np.sum((d.apply(P) - Q) ** 2, axis=1)
    pos = sigma > 0
    return float(np.mean(r2[pos] / (2.0 * sigma[pos] ** 2)))


def discrepancy_smoothing(
    source_uv: FloatArray,
    target_uv: FloatArray,
    noise: FloatArray,
    *,
    kernel_scale: FloatArray | None = None,
    chi: float = 1.0,
    boundary_taper: bool = True,
) -> LandmarkSmoothing:
    """Per-landmark thin-plate smoothing whose residuals match the landmarks' noise.

    Parameters
    ----------
    source_uv : (m, 2) float64
        Landmarks P inside the unit disk (e.g. after the Möbius part).
    target_uv : (m, 2) float64
        Landmarks Q.
    noise : (m,) float64
        Standard deviation σ_i ≥ 0 of landmark i's error per coordinate, in disk
        units (0: a landmark known exactly, interpolated).
    kernel_scale : (m,) float64, optional
        As in :func:`~conformorph.geometry.thin_plate_registration.thin_plate_registration`.
    chi : float, default 1
        Target ratio of the residuals to the noise (> 0).
    boundary_taper : bool, default True
        As in :func:`~conformorph.geometry.thin_plate_registration.thin_plate_registration`.

    Returns
    -------
    LandmarkSmoothing

    Raises
    ------
    ValueError
        On bad shapes, fewer than 3 landmarks, negative or non-finite noise, or
        a non-positive ``chi``.

    Examples
    --------
    >>> import numpy as np
    >>> P = np.array([[0.0, 0.0], [0.3, 0.1], [-0.2, 0.3], [0.1, -0.4], [-0.3, -0.2]])
    >>> Q = P + np.array([[0.02, 0.0], [0.0, 0.01], [-0.01, 0.0], [0.0, 0.0], [0.01, 0.01]])
    >>> s = discrepancy_smoothing(P, Q, np.zeros(5))
    >>> float(s.kappa), bool(np.all(s.smoothing == 0))
    (0.0, True)
    """
    P = np.asarray(source_uv, dtype=np.float64)
    Q = np.asarray(target_uv, dtype=np.float64)
    sigma = np.asarray(noise, dtype=np.float64)
    m = P.shape[0] if P.ndim == 2 else -1
    if P.ndim != 2 or P.shape[1] != 2 or P.shape != Q.shape or m < 3:
        raise ValueError(
            f"source_uv and target_uv must both be (m, 2), m ≥ 3; got {P.shape}, {Q.shape}"
        )
    if sigma.shape != (m,) or not np.all(np.isfinite(sigma)) or np.any(sigma < 0):
        raise ValueError(f"noise must be ({m},) non-negative and finite, got {sigma.shape}")
    if not (np.isfinite(chi) and chi > 0):
        raise ValueError(f"chi must be positive, got {chi}")
    if not np.any(sigma > 0):
        return LandmarkSmoothing(np.zeros(m), 0.0, 0.0, False)
    lo, hi = np.log(KAPPA_RANGE[0]), np.log(KAPPA_RANGE[1])
    c_hi = _chi(P, Q, sigma, float(np.exp(hi)), kernel_scale, boundary_taper)
    if c_hi <= chi:
        return LandmarkSmoothing(float(np.exp(hi)) * sigma**2, float(np.exp(hi)), c_hi, True)
    c_mid = c_hi
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        c_mid = _chi(P, Q, sigma, float(np.exp(mid)), kernel_scale, boundary_taper)
        if c_mid > chi:
            hi = mid
        else:
            lo = mid
    kappa = float(np.exp(lo))
    return LandmarkSmoothing(
        kappa * sigma**2, kappa, _chi(P, Q, sigma, kappa, kernel_scale, boundary_taper), False
    )
