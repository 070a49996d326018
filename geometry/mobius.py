"""Möbius transformations of the unit disk and the normalisation of disk maps."""

from __future__ import annotations

import numpy as np

from ._typing import ComplexArray, FloatArray, IntArray


def mobius_disk(z: ComplexArray, a: complex, theta: float = 0.0) -> ComplexArray:
    """The disk automorphism ``z ↦ e^{iθ} (z − a) / (1 − ā z)``.

    Parameters
    ----------
    z : (n,) complex128
        Points in the closed unit disk.
    a : complex
        The point sent to 0; ``|a| < 1``.
    theta : float
        Rotation after the transform, radians.

    Returns
    -------
    w : (n,) complex128
        Images; the unit circle maps onto itself.

    Raises
    ------
    ValueError
        If ``|a| >= 1``.
    """
    if not abs(a) < 1.0:
        raise ValueError(f"Möbius parameter must lie inside the unit disk, got |a| = {abs(a):.6g}")
    return np.exp(1j * theta) * (z - a) / (1.0 - np.conj(a) * z)


def normalize_disk_map(
    uv: FloatArray,
    b: IntArray,
    center_vertex: int | None = None,
    angle_vertex: int | None = None,
) -> FloatArray:
    """Apply the Möbius transform that fixes the disk map's remaining freedom.

    Parameters
    ----------
    uv : (n, 2) float64
        A disk map, boundary vertices on the unit circle.
    b : (k,) int64
        Boundary vertices.
    center_vertex : int, optional
        Vertex sent to the origin.
    angle_vertex : int, optional
        Boundary vertex sent to angle 0 (the point (1, 0)).

    Returns
    -------
    uv : (n, 2) float64
        A new array; boundary vertices are re-projected onto the circle to
        remove round-off.

    Raises
    ------
    ValueError
        If ``angle_vertex`` is not a boundary vertex or an index is out of range.
    """
    n = uv.shape[0]
    z = uv[:, 0] + 1j * uv[:, 1]
    for name, v in (("center_vertex", center_vertex), ("angle_vertex", angle_vertex)):
        if v is not None and not 0 <= int(v) < n:
            raise ValueError(f"{name} {v} is out of range 0..{n - 1}")
    if center_vertex is not None:
        a = complex(z[int(center_vertex)])
        if abs(a) >= 1.0:
            raise ValueError(f"center_vertex {center_vertex} lies on the boundary; pick an interior one")
        z = mobius_disk(z, a)
    if angle_vertex is not None:
        if int(angle_vertex) not in set(b.tolist()):
            raise ValueError(f"angle_vertex {angle_vertex} is not a boundary vertex")
        z = z * np.exp(-1j * np.angle(z[int(angle_vertex)]))
    z[b] = z[b] / np.abs(z[b])
    return np.stack([z.real, z.imag], axis=1)
