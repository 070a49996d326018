"""Angle distortion of a parameterisation: 3D corner angles against 2D ones."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray


def corner_angles(V: FloatArray, F: IntArray) -> FloatArray:
    """Interior angles of every triangle corner.

    Parameters
    ----------
    V : (n, d) float64
        Positions, d = 2 or 3.
    F : (m, 3) int64

    Returns
    -------
    angles : (m, 3) float64
        Radians; ``angles[f, k]`` is the angle at vertex ``F[f, k]``.
        Computed with ``atan2(|a×b|, a·b)``, accurate also for angles near 0
        and π (``arccos`` of the normalised dot product is not).
    """
    P = V[F]  # (m, 3, d)
    E = np.roll(P, -1, axis=1) - P  # E[:, k] = P[:, k+1] - P[:, k]
    # corner k's edges are a = E_k and b = -E_{k-1}; |a × b| is twice the
    # triangle's area at every corner, so one cross product per triangle serves
    e1, e2 = E[:, 0], -E[:, 2]
    if V.shape[1] == 2:
        cross = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    else:
        cx = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
        cy = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
        cz = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        cross = np.sqrt(cx * cx + cy * cy + cz * cz)
    dot = -np.einsum("mkd,mkd->mk", E, np.roll(E, 1, axis=1))
    return np.asarray(np.arctan2(cross[:, None], dot), dtype=np.float64)


def angle_distortion(V: FloatArray, F: IntArray, uv: FloatArray) -> FloatArray:
    """Absolute difference between 3D and 2D corner angles, in degrees.

    Parameters
    ----------
    V : (n, 3) float64
        Surface.
    F : (m, 3) int64
    uv : (n, 2) float64
        Parameterisation.

    Returns
    -------
    d : (m, 3) float64
        ``|∠_3D − ∠_2D|`` per corner, degrees. For a flipped 2D triangle the
        unsigned 2D angles are used, so flips must be counted separately
        (:func:`geometry.flipped_triangles`).

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> F = np.array([[0, 1, 2]])
    >>> angle_distortion(V, F, V[:, :2] * 3.0).round(12)
    array([[0., 0., 0.]])
    """
    return np.degrees(np.abs(corner_angles(V, F) - corner_angles(uv, F)))
