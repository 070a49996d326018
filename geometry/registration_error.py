"""Landmark correspondence errors of a disk registration: eq. (2) E_D and eq. (3) E.

Section 3 of the face morphing paper measures how well a registration map
:math:`\\bar f` of the disk takes landmarks P to Q on the disk (E_D) and, through
the inverse parameterisation, on the surface (E).
"""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .point_location import PointLocator


def disk_registration_error(mapped_source_uv: FloatArray, target_uv: FloatArray) -> float:
    """Eq. (2): :math:`E_D(\\bar f) = (\\sum_i |\\bar f(p_i) - q_i|^2)^{1/2}`.

    Parameters
    ----------
    mapped_source_uv : (m, 2) float64
        :math:`\\bar f(p_i)`, the source landmarks after the registration map.
    target_uv : (m, 2) float64
        Target landmarks :math:`q_i` on the target disk.

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> disk_registration_error(np.array([[0.0, 0.0], [0.3, 0.0]]), np.array([[0.0, 0.4], [0.0, 0.0]]))
    0.5
    """
    a = np.asarray(mapped_source_uv, dtype=np.float64)
    b = np.asarray(target_uv, dtype=np.float64)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 2:
        raise ValueError(f"landmark sets must both be (m, 2), got {a.shape} and {b.shape}")
    return float(np.sqrt(np.sum((a - b) ** 2)))


def surface_registration_error(
    mapped_source_uv: FloatArray,
    target_uv: FloatArray,
    target_V: FloatArray,
    target_F: IntArray,
    target_landmarks: FloatArray,
    *,
    locator: PointLocator | None = None,
) -> float:
    """Eq. (3): :math:`E(f) = (\\sum_i |\\varphi_1^{-1}(\\bar f(p_i)) - \\varphi_1^{-1}(q_i)|^2)^{1/2}`.

    Since :math:`f = \\varphi_1^{-1} \\circ \\bar f \\circ \\varphi_0`,
    :math:`f \\circ \\varphi_0^{-1}(p_i) = \\varphi_1^{-1}(\\bar f(p_i))`: the mapped
    landmark is lifted to the target surface by barycentric interpolation in
    the target disk map.

    Parameters
    ----------
    mapped_source_uv : (m, 2) float64
        :math:`\\bar f(p_i)`.
    target_uv : (n, 2) float64
        Disk map :math:`\\varphi_1` of the target surface (per vertex).
    target_V : (n, 3) float64
        Target surface (normalised, if E is to be compared across inputs).
    target_F : (k, 3) int64
        Target triangles.
    target_landmarks : (m, 3) float64
        :math:`\\varphi_1^{-1}(q_i)`, the target landmarks on the surface.
    locator : PointLocator, optional
        A prepared locator of (target_uv, target_F), reused if given.

    Returns
    -------
    float
    """
    x = np.asarray(mapped_source_uv, dtype=np.float64)
    V = np.asarray(target_V, dtype=np.float64)
    F = np.asarray(target_F, dtype=np.int64)
    Y = np.asarray(target_landmarks, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 2 or Y.shape != (x.shape[0], 3):
        raise ValueError(
            f"expected (m, 2) mapped landmarks and (m, 3) targets, got {x.shape}, {Y.shape}"
        )
    if V.shape[0] != np.asarray(target_uv).shape[0]:
        raise ValueError("target_uv and target_V must have one row per vertex")
    loc = (locator or PointLocator(target_uv, F)).locate(x)
    X = loc.interpolate(F, V)
    return float(np.sqrt(np.sum((X - Y) ** 2)))
