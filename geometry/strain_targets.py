"""The strain field a frame of the strain morph should have: ε^n (eq. 1), ε^t (eq. 2 / eq. 3)
and the area ratio it prescribes."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray
from .green_lagrange_strain import StrainScheme, interpolate_strain


def prescribed_area_ratio(eps: FloatArray) -> FloatArray:
    """Area ratio ``det J = sqrt(det(I + 2E))`` that a strain prescribes, per triangle.

    Parameters
    ----------
    eps : (m, 3) float64
        ``[ε_x, ε_y, γ_xy]``.

    Returns
    -------
    (m,) float64
        Positive; a strain no deformation realises (``det(I + 2E) ≤ 0``, which eq. 3
        can prescribe mid-way) gets the floor 1e-3.

    Examples
    --------
    >>> import numpy as np
    >>> prescribed_area_ratio(np.array([[1.5, 0.0, 0.0], [0.0, 0.0, 0.0]])).tolist()
    [2.0, 1.0]
    """
    det_c = (1.0 + 2.0 * eps[:, 0]) * (1.0 + 2.0 * eps[:, 1]) - eps[:, 2] ** 2
    return np.asarray(np.sqrt(np.maximum(det_c, 1e-6)), dtype=np.float64)


def strain_target(
    eps_n: FloatArray, t: float, scheme: StrainScheme
) -> tuple[FloatArray, FloatArray]:
    """The strain ε^t a frame at time t must have, and the area ratio it prescribes.

    ε^t is eq. (2) (``scheme="linear"``: ``t ε^n``) or eq. (3) (``"modified"``,
    or ``"principal"``: eq. 3 in each triangle's principal frame), see
    :func:`conformorph.geometry.green_lagrange_strain.interpolate_strain`.

    Parameters
    ----------
    eps_n : (m, 3) float64
        Final strain field ε^n (eq. 1) of source → target.
    t : float
        Time in [0, 1].
    scheme : {"modified", "linear", "principal"}

    Returns
    -------
    eps_t : (m, 3) float64
        ``[ε_x, ε_y, γ_xy]`` per triangle.
    d_star : (m,) float64
        :func:`prescribed_area_ratio` of ``eps_t`` (the barrier's reference).
    """
    eps_t = interpolate_strain(eps_n, t, scheme=scheme)
    return eps_t, prescribed_area_ratio(eps_t)
