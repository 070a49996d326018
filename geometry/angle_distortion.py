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
    _, cross, dot = corner_edge_products(V, F)
    return np.asarray(np.arctan2(np.abs(cross)[:, None], dot), dtype=np.float64)


def corner_edge_products(V: FloatArray, F: IntArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Edge vectors of every triangle, twice its area, and the dot products at its corners.

    Parameters
    ----------
    V : (n, d) float64
        Positions, d = 2 or 3.
    F : (m, 3) int64

    Returns
    -------
    E : (m, 3, d) float64
        ``E[f, k] = V[F[f, k+1]] − V[F[f, k]]``.
    cross : (m,) float64
        ``a × b`` of the two edges ``a = E[f, k]``, ``b = −E[f, k−1]`` leaving
        any corner: the same at all three corners, twice the triangle's area,
        signed for d = 2 (positive counter-clockwise), its norm for d = 3.
    dot : (m, 3) float64
        ``a · b`` at corner k; the angle at ``F[f, k]`` is ``atan2(cross, dot)``.
    """
    P = V[F]  # (m, 3, d)
    E = np.roll(P, -1, axis=1) - P
    e1, e2 = E[:, 0], -E[:, 2]
    if V.shape[1] == 2:
        cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    else:
        cx = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
        cy = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
        cz = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        cross = np.sqrt(cx * cx + cy * cy + cz * cz)
    dot = -np.einsum("mkd,mkd->mk", E, np.roll(E, 1, axis=1))
    return E, cross, dot


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
        (:func:`conformorph.geometry.flipped_triangles`).

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> F = np.array([[0, 1, 2]])
    >>> angle_distortion(V, F, V[:, :2] * 3.0).round(12)
    array([[0., 0., 0.]])
    """
    return np.degrees(np.abs(corner_angles(V, F) - corner_angles(uv, F)))
