"""The closed unit disk onto the polygon inscribed by a disk map's boundary, radially."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray


def retract_to_boundary_polygon(
    points: FloatArray, boundary_uv: FloatArray, *, band: float = 4.0
) -> FloatArray:
    """Move points of the closed unit disk into the polygon of a disk mesh's boundary.

    A disk map puts its boundary vertices on the unit circle, so its triangles
    cover only the inscribed polygon; a registration map of the disk onto
    itself may send a point into the sliver between a chord and its arc.
    Snapping such points to the nearest point of the mesh sends whole
    neighbourhoods onto the chord and folds the triangles there. This map is
    instead a homeomorphism of the disk onto the polygon that moves nothing
    outside a thin band at the rim: along the ray at angle θ, with ``ρ(θ)``
    the distance from 0 to the polygon, the radii ``[a, 1]`` are mapped
    affinely onto ``[a, ρ(θ)]``, where ``a = max(0, 1 − band · (1 − min ρ))``. It is
    continuous, and increasing along every ray, so it keeps orientation.

    Parameters
    ----------
    points : (p, 2) float64
        Points with ``|z| ≤ 1`` (larger radii are first clamped to 1).
    boundary_uv : (k, 2) float64
        The boundary polygon: points on the unit circle (k ≥ 3), in any order,
        containing the origin.
    band : float
        Width of the band that moves, in units of the largest chord sagitta.

    Returns
    -------
    (p, 2) float64
        New array; points with ``|z| ≤ a`` are returned unchanged.

    Raises
    ------
    ValueError
        If shapes are wrong, ``band < 1``, or the polygon does not contain the origin.

    Examples
    --------
    The square inscribed in the unit circle: the point (1, 0) on the circle goes
    to the square's corner (1, 0) itself, and (0.7071, 0.7071)·1 at 45°, the middle
    of an arc, goes to the middle of its chord, at radius √2/2.

    >>> import numpy as np
    >>> sq = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])
    >>> out = retract_to_boundary_polygon(np.array([[1.0, 0], [0.5**0.5, 0.5**0.5]]), sq)
    >>> np.round(out, 6).tolist()
    [[1.0, 0.0], [0.5, 0.5]]
    """
    P = np.asarray(points, dtype=np.float64)
    B = np.asarray(boundary_uv, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2:
        raise ValueError(f"points must have shape (p, 2), got {P.shape}")
    if B.ndim != 2 or B.shape[1] != 2 or B.shape[0] < 3:
        raise ValueError(f"boundary_uv must have shape (k ≥ 3, 2), got {B.shape}")
    if band < 1.0:
        raise ValueError(f"band must be at least 1, got {band}")
    ang = np.arctan2(B[:, 1], B[:, 0])
    order = np.argsort(ang)
    ang, B = ang[order], B[order]
    gaps = np.diff(np.concatenate([ang, [ang[0] + 2 * np.pi]]))
    if gaps.max() >= np.pi:
        raise ValueError("the boundary polygon does not contain the origin")
    # distance from 0 to each chord (B_j, B_{j+1}), and the unit normal pointing outwards
    nxt = np.roll(B, -1, axis=0)
    edge = nxt - B
    normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    dist = np.abs(np.einsum("ij,ij->i", B, normal))
    normal *= np.sign(np.einsum("ij,ij->i", B, normal))[:, None]
    a = max(0.0, 1.0 - band * (1.0 - float(dist.min())))
    out = P.copy()
    r = np.hypot(P[:, 0], P[:, 1])
    move = r > a
    if not move.any():
        return out
    rm = np.minimum(r[move], 1.0)
    u = P[move] / r[move, None]
    theta = np.arctan2(u[:, 1], u[:, 0])
    j = (np.searchsorted(ang, theta, side="right") - 1) % B.shape[0]
    # the ray t·u meets the chord j where t (u · n_j) = dist_j
    rho = dist[j] / np.einsum("ij,ij->i", u, normal[j])
    r_new = a + (rm - a) * (rho - a) / (1.0 - a)
    out[move] = u * r_new[:, None]
    return out
