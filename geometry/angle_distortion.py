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
    out = np.zeros(F.shape, dtype=np.float64)
    for k in range(3):
        a = V[F[:, (k + 1) % 3]] - V[F[:, k]]
        b = V[F[:, (k + 2) % 3]] - V[F[:, k]]
        dot = np.einsum("ij,ij->i", a, b)
        if V.shape[1] == 2:
            cross = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        else:
            cross = np.linalg.norm(np.cross(a, b), axis=1)
        out[:, k] = np.arctan2(cross, dot)
    return out


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
