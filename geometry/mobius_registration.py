"""MT: the Möbius transformation of the unit disk that best matches two landmark sets.

Section 3 of the face morphing paper (Yueh, Gu, Lin, Wu, Yau): registration
"via the optimal Möbius transformation (MT)". The automorphisms of the unit
disk are :math:`z \\mapsto e^{i\\theta}(z-a)/(1-\\bar a z)` with :math:`|a|<1`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ._typing import FloatArray
from .landmark_pairs import landmark_rms, validate_landmark_pairs
from .registration_error import disk_registration_error

#: |a| of a fitted transformation is kept at most this (a Möbius map with |a|→1
#: collapses the disk onto a boundary point).
MOBIUS_MAX_ABS_A = 0.999


@dataclass(frozen=True)
class MobiusTransform:
    """The disk automorphism :math:`z \\mapsto e^{i\\theta}(z-a)/(1-\\bar a z)`.

    Attributes
    ----------
    a : complex
        The point sent to the origin; ``|a| < 1``.
    theta : float
        Rotation angle (radians).
    """

    a: complex
    theta: float

    def __post_init__(self) -> None:
        if not np.isfinite(self.a) or not np.isfinite(self.theta):
            raise ValueError("Möbius parameters must be finite")
        if abs(self.a) >= 1.0:
            raise ValueError(f"|a| must be < 1 for a disk automorphism, got {abs(self.a)}")

    def apply(self, uv: FloatArray) -> FloatArray:
        """Apply to points.

        Parameters
        ----------
        uv : (p, 2) float64

        Returns
        -------
        (p, 2) float64
        """
        uv = np.asarray(uv, dtype=np.float64)
        z = uv[:, 0] + 1j * uv[:, 1]
        w = np.exp(1j * self.theta) * (z - self.a) / (1.0 - np.conj(self.a) * z)
        return np.stack([w.real, w.imag], axis=1)

    def inverse(self) -> MobiusTransform:
        """The inverse transformation (again a disk automorphism)."""
        # w = e^{iθ}(z−a)/(1−āz)  ⇔  z = (w e^{−iθ} + a)/(1 + ā e^{−iθ} w)
        #   = e^{−iθ}(w + a e^{iθ}) / (1 + conj(a e^{iθ}) w)
        b = -self.a * np.exp(1j * self.theta)
        return MobiusTransform(complex(b), float(-self.theta))

    def jacobian_determinant(self, uv: FloatArray) -> FloatArray:
        """Jacobian determinant |f'(z)|² at points (positive: Möbius maps are conformal).

        Parameters
        ----------
        uv : (p, 2) float64

        Returns
        -------
        (p,) float64
        """
        z = uv[:, 0] + 1j * uv[:, 1]
        d = (1.0 - abs(self.a) ** 2) / (1.0 - np.conj(self.a) * z) ** 2
        return np.asarray(np.abs(d) ** 2)


@dataclass(frozen=True)
class MobiusRegistrationInfo:
    """Diagnostics of :func:`mobius_registration`.

    Attributes
    ----------
    rms : float
        Root-mean-square landmark distance after the fit.
    error : float
        E_D of eq. (2): sqrt of the sum of squared landmark distances.
    n_starts : int
        Number of starting points tried.
    nfev : int
        Total residual evaluations.
    """

    rms: float
    error: float
    n_starts: int
    nfev: int


def _params_to_a(x: FloatArray) -> complex:
    # |a| = tanh(|w|) < 1 for any w in R²: an unconstrained parameterisation
    w = complex(x[0], x[1])
    r = abs(w)
    if r == 0:
        return 0j
    return complex(np.tanh(r) * w / r)


def _a_to_params(a: complex) -> tuple[float, float]:
    r = abs(a)
    if r == 0:
        return 0.0, 0.0
    s = np.arctanh(min(r, MOBIUS_MAX_ABS_A)) / r
    return float(a.real * s), float(a.imag * s)


def mobius_registration(
    source_uv: FloatArray,
    target_uv: FloatArray,
    *,
    weights: FloatArray | None = None,
) -> tuple[MobiusTransform, MobiusRegistrationInfo]:
    """Fit the disk Möbius transformation that best maps one landmark set onto another.

    Minimises :math:`\\sum_i w_i |M(p_i) - q_i|^2` over :math:`a` (``|a| < 1``)
    and :math:`\\theta`, with Levenberg–Marquardt-type least squares from
    several starts (the identity, the best pure rotation, and ``a`` at the
    landmarks' centroid), keeping the best.

    Parameters
    ----------
    source_uv : (m, 2) float64
        Landmarks P on the source disk (inside the closed unit disk).
    target_uv : (m, 2) float64
        Corresponding landmarks Q on the target disk.
    weights : (m,) float64, optional
        Non-negative weights, default all 1.

    Returns
    -------
    transform : MobiusTransform
    info : MobiusRegistrationInfo

    Raises
    ------
    ValueError
        On shape mismatch, fewer than 2 landmarks, non-finite input or points
        outside the closed unit disk.

    Notes
    -----
    ``a`` is parameterised as ``tanh(|w|) w/|w|`` for ``w`` in R², so that
    ``|a| < 1`` holds for every iterate; fits are additionally capped at
    :data:`MOBIUS_MAX_ABS_A`.

    Examples
    --------
    >>> import numpy as np
    >>> M = MobiusTransform(0.2 - 0.1j, 0.5)
    >>> P = np.array([[0.1, 0.2], [-0.3, 0.4], [0.5, -0.2], [0.0, -0.6]])
    >>> T, info = mobius_registration(P, M.apply(P))
    >>> bool(abs(T.a - M.a) < 1e-8 and abs(T.theta - M.theta) < 1e-8)
    True
    """
    P, Q = validate_landmark_pairs(
        source_uv, target_uv, min_count=2, fit="a Möbius transformation", disk="closed"
    )
    m = P.shape[0]
    w = np.ones(m) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (m,) or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ValueError(f"weights must be (m,) = ({m},) non-negative and finite")
    sw = np.sqrt(w)
    p = P[:, 0] + 1j * P[:, 1]
    q = Q[:, 0] + 1j * Q[:, 1]

    def residual(x: FloatArray) -> FloatArray:
        a = _params_to_a(x)
        r = np.exp(1j * x[2]) * (p - a) / (1.0 - np.conj(a) * p) - q
        return np.concatenate([sw * r.real, sw * r.imag])

    def rotation_start(a: complex) -> float:
        z = (p - a) / (1.0 - np.conj(a) * p)
        return float(np.angle(np.sum(w * np.conj(z) * q)))

    a_centroid = complex(np.average(p, weights=w) if w.sum() > 0 else 0.0)
    if abs(a_centroid) >= MOBIUS_MAX_ABS_A:
        a_centroid = 0j
    # the map sending the source centroid to 0, then 0 back to the target centroid
    starts = [(0j, 0.0), (0j, rotation_start(0j)), (a_centroid, rotation_start(a_centroid))]
    sols = [
        least_squares(
            residual,
            np.array([*_a_to_params(a0), th0]),
            method="lm",
            xtol=1e-14,
            ftol=1e-14,
            gtol=1e-14,
        )
        for a0, th0 in starts
    ]
    nfev = sum(int(s.nfev) for s in sols)
    best = min(sols, key=lambda s: float(s.cost))
    a = _params_to_a(best.x)
    if abs(a) > MOBIUS_MAX_ABS_A:
        a = a / abs(a) * MOBIUS_MAX_ABS_A
    theta = float(np.angle(np.exp(1j * best.x[2])))
    T = MobiusTransform(a, theta)
    mapped = T.apply(P)
    info = MobiusRegistrationInfo(
        rms=landmark_rms(mapped, Q),
        error=disk_registration_error(mapped, Q),
        n_starts=len(starts),
        nfev=nfev,
    )
    return T, info
