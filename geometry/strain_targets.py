"""The strain field a frame of the strain morph should have: ε^n (eq. 1), ε^t (eq. 2 / eq. 3)
and the area ratio it prescribes."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray
from .green_lagrange_strain import StrainScheme, interpolate_strain
from .tolerances import STRAIN_AREA_SLACK


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
    eps_n: FloatArray,
    t: float,
    scheme: StrainScheme,
    rest_areas: FloatArray | None = None,
    area_gain: float = 1.0,
) -> tuple[FloatArray, FloatArray]:
    """The strain ε^t a frame at time t must have, and the area ratio it prescribes.

    ε^t is eq. (2) (``scheme="linear"``: ``t ε^n``) or eq. (3) (``"modified"``,
    or ``"principal"``: eq. 3 in each triangle's principal frame), see
    :func:`conformorph.geometry.green_lagrange_strain.interpolate_strain`.

    With ``rest_areas``, a total prescribed area ``Σ a d_t`` more than
    ``STRAIN_AREA_SLACK`` outside the range of the end frames' (``Σ a`` and
    ``Σ a d_n``) is brought back to the slack's edge by dilating ε^t uniformly:
    ``C_t ← c(t) C_t`` (C = I + 2ε), which scales every triangle's prescribed
    area ratio d_t by c(t) and keeps its shape (principal stretch ratio and
    axes); inside the range ε^t is eq. (2)/(3)'s exactly. ``area_gain`` is the
    ratio of the area a solved frame has to the area its strain prescribed (the
    strains are not compatible, so the minimiser of W does not realise them):
    the bound is then applied to ``area_gain · Σ a d_t``, the area the frame is
    expected to get. Eq. (3) interpolates stretches linearly, so a triangle stretched and
    squashed by the same factor (area kept) gains ``t(1 − t)(λ₁ + λ₂ − 2)`` of its
    area mid-way; summed over the shape, the outline of L → T (no anchors) swelled
    to 1.49 of the source's area where the target has about 1.1: the bar pair's
    "no squeezing beyond the endpoints" rule broken on the whole shape. The end
    frames are unchanged (``c(0) = c(1) = 1`` up to round-off).

    Parameters
    ----------
    eps_n : (m, 3) float64
        Final strain field ε^n (eq. 1) of source → target.
    t : float
        Time in [0, 1].
    scheme : {"modified", "linear", "principal"}
    rest_areas : (m,) float64, optional
        Triangle areas of the source; given, the total prescribed area is kept
        between the end frames' (above). None (default): eq. (2)/(3) as the paper.
    area_gain : float, optional
        Solved over prescribed total area of a recent frame (default 1).

    Returns
    -------
    eps_t : (m, 3) float64
        ``[ε_x, ε_y, γ_xy]`` per triangle.
    d_star : (m,) float64
        :func:`prescribed_area_ratio` of ``eps_t`` (the barrier's reference).
    """
    eps_t = interpolate_strain(eps_n, t, scheme=scheme)
    d_t = prescribed_area_ratio(eps_t)
    if rest_areas is None or t <= 0.0 or t >= 1.0:
        return eps_t, d_t
    a = np.asarray(rest_areas, dtype=np.float64)
    ends = (float(a.sum()), float(a @ prescribed_area_ratio(eps_n)))
    total = float(a @ d_t) * area_gain
    lo, hi = min(ends) * (1.0 - STRAIN_AREA_SLACK), max(ends) * (1.0 + STRAIN_AREA_SLACK)
    if lo <= total <= hi:
        return eps_t, d_t
    c = min(max(total, lo), hi) / total  # continuous in t: to the slack's edge
    dilated = eps_t.copy()
    dilated[:, :2] = 0.5 * (c * (1.0 + 2.0 * eps_t[:, :2]) - 1.0)
    dilated[:, 2] = c * eps_t[:, 2]
    return dilated, c * d_t
