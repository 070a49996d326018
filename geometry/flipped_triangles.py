"""Orientation of triangles in the plane."""

from __future__ import annotations

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray


def signed_areas_2d(uv: FloatArray, F: IntArray) -> FloatArray:
    """Signed areas of planar triangles (positive = counter-clockwise).

    Parameters
    ----------
    uv : (n, 2) float64
    F : (m, 3) int64

    Returns
    -------
    a : (m,) float64
    """
    p, q, r = uv[F[:, 0]], uv[F[:, 1]], uv[F[:, 2]]
    return 0.5 * (
        (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])
    )


def flipped_triangles(uv: FloatArray, F: IntArray) -> BoolArray:
    """Triangles whose image is clockwise or degenerate (signed area ≤ 0).

    Parameters
    ----------
    uv : (n, 2) float64
        A parameterisation whose valid orientation is counter-clockwise.
    F : (m, 3) int64

    Returns
    -------
    flipped : (m,) bool
    """
    return np.asarray(signed_areas_2d(uv, F) <= 0.0)


def max_orientation_step(U: FloatArray, D: FloatArray) -> float:
    """Largest ``α`` with ``det(U_t + s D_t) > 0`` for every t and every ``0 ≤ s < α``.

    ``det(U + s D)`` is a quadratic in s; its smallest positive root bounds a line
    search that must keep every triangle positively oriented (Smith and Schaefer
    2015). Used with edge matrices (a map's triangles) or deformation gradients.

    Parameters
    ----------
    U : (m, 2, 2) float64
        Current matrices, each with positive determinant.
    D : (m, 2, 2) float64
        Their change per unit step.

    Returns
    -------
    float
        ``inf`` when no determinant ever reaches 0 along the step.

    References
    ----------
    J. Smith, S. Schaefer, "Bijective Parameterization with Free Boundaries",
    ACM Trans. Graph. 34(4) (2015), doi:10.1145/2766947.

    Examples
    --------
    The unit square's matrix shrunk along x collapses at s = 1:

    >>> import numpy as np
    >>> max_orientation_step(np.eye(2)[None], np.array([[[-1.0, 0], [0, 0]]]))
    1.0
    """
    qa = D[:, 0, 0] * D[:, 1, 1] - D[:, 0, 1] * D[:, 1, 0]
    qc = U[:, 0, 0] * U[:, 1, 1] - U[:, 0, 1] * U[:, 1, 0]
    qb = (
        U[:, 0, 0] * D[:, 1, 1]
        + D[:, 0, 0] * U[:, 1, 1]
        - U[:, 0, 1] * D[:, 1, 0]
        - D[:, 0, 1] * U[:, 1, 0]
    )
    roots = np.full(qa.shape[0], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        lin = np.abs(qa) <= 1e-14 * np.maximum(np.abs(qb) + np.abs(qc), 1e-300)
        t = -qc / qb
        roots = np.where(lin & (t > 0), t, roots)
        disc = qb * qb - 4.0 * qa * qc
        ok = ~lin & (disc >= 0)
        sq = np.sqrt(np.where(ok, disc, 0.0))
        for r in ((-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa)):
            roots = np.minimum(roots, np.where(ok & (r > 0), r, np.inf))
    return float(roots.min(initial=np.inf))
