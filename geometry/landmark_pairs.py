"""Corresponding landmark sets on the disk: the checks and residuals every landmark fit shares.

Section 3 of the face morphing paper registers landmark sets
:math:`P = \\{p^{(i)}\\}` and :math:`Q = \\{q^{(i)}\\}` on the unit disk, first by
the optimal Möbius transformation (:mod:`conformorph.geometry.mobius_registration`), then
by the modified thin-plate spline (:mod:`conformorph.geometry.thin_plate_registration`).
Both fits validate their input the same way and report the same residuals;
this module is the one place that does so.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from ._typing import FloatArray
from .registration_error import disk_registration_error

#: slack of the closed-unit-disk test (points computed by a disk map may
#: overshoot the circle by rounding)
DISK_SLACK = 1e-9


def validate_landmark_pairs(
    source_uv: FloatArray,
    target_uv: FloatArray,
    *,
    min_count: int,
    fit: str,
    disk: Literal["closed", None] = None,
) -> tuple[FloatArray, FloatArray]:
    """Check two corresponding landmark sets on the disk and return them as float arrays.

    Parameters
    ----------
    source_uv : (m, 2) array_like
        Landmarks P.
    target_uv : (m, 2) array_like
        Corresponding landmarks Q.
    min_count : int
        Fewest landmarks the fit needs.
    fit : str
        Name of the fit, for the error messages (e.g. ``"a Möbius transformation"``).
    disk : {"closed", None}, default None
        ``"closed"``: both sets must lie in the closed unit disk
        (:data:`DISK_SLACK` allowed).

    Returns
    -------
    P, Q : (m, 2) float64

    Raises
    ------
    ValueError
        On shape mismatch, fewer than ``min_count`` landmarks, non-finite
        coordinates, or (``disk="closed"``) points outside the closed disk.

    Examples
    --------
    >>> P, Q = validate_landmark_pairs([[0, 0], [0.5, 0]], [[0.1, 0], [0.4, 0]], min_count=2, fit="x")
    >>> P.dtype.name, Q.shape
    ('float64', (2, 2))
    """
    P = np.asarray(source_uv, dtype=np.float64)
    Q = np.asarray(target_uv, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape != Q.shape:
        raise ValueError(
            f"source_uv and target_uv must both be (m, 2), got {P.shape} and {Q.shape}"
        )
    m = P.shape[0]
    if m < min_count:
        raise ValueError(f"need at least {min_count} landmarks to fit {fit}, got {m}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(Q))):
        raise ValueError("landmarks have non-finite coordinates")
    if disk == "closed":
        r = max(float(np.hypot(*P.T).max()), float(np.hypot(*Q.T).max()))
        if r > 1.0 + DISK_SLACK:
            raise ValueError(f"landmarks must lie in the closed unit disk (found |z| = {r:.6g})")
    elif disk is not None:
        raise ValueError(f"disk must be 'closed' or None, got {disk!r}")
    return P, Q


def landmark_rms(mapped_uv: FloatArray, target_uv: FloatArray) -> float:
    """Root-mean-square landmark distance :math:`(\\frac1m\\sum_i |\\bar f(p_i) - q_i|^2)^{1/2}`.

    Equals :math:`E_D / \\sqrt m` with E_D of eq. (2)
    (:func:`conformorph.geometry.registration_error.disk_registration_error`).

    Parameters
    ----------
    mapped_uv, target_uv : (m, 2) float64

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> round(landmark_rms(np.array([[0.0, 0.0], [0.3, 0.0]]), np.array([[0.0, 0.4], [0.0, 0.0]])), 12)
    0.353553390593
    """
    a = np.asarray(mapped_uv, dtype=np.float64)
    if a.ndim != 2 or a.shape[0] == 0:
        raise ValueError(f"landmark sets must be (m, 2) with m ≥ 1, got {a.shape}")
    return disk_registration_error(a, target_uv) / float(np.sqrt(a.shape[0]))
