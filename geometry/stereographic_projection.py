"""Stereographic projection, and the passage from a hemisphere map to an exact disk map."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .cotangent_laplacian import cotangent_laplacian
from .flipped_triangles import signed_areas_2d
from .sparse_factor import Factorization, factorize


def stereographic_projection(P: FloatArray) -> FloatArray:
    """Stereographic projection from the south pole onto the equatorial plane.

    Parameters
    ----------
    P : (n, 3) float64
        Points on the unit sphere. Not modified.

    Returns
    -------
    uv : (n, 2) float64
        ``(x, y) / (1 + z)``: the northern hemisphere goes to the closed unit
        disk, the equator to the unit circle, the north pole to 0. The map is
        conformal and orientation-preserving when the sphere is seen from
        outside above the plane.

    Raises
    ------
    ValueError
        If a point is (numerically) at the south pole or P has the wrong shape.

    Examples
    --------
    >>> import numpy as np
    >>> stereographic_projection(np.array([[0., 0, 1], [1, 0, 0]]))
    array([[0., 0.],
           [1., 0.]])
    """
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"P must have shape (n, 3), got {P.shape}")
    d = 1.0 + P[:, 2]
    if np.any(d <= 1e-12):
        raise ValueError("a point lies at the south pole, whose projection is at infinity")
    return P[:, :2] / d[:, None]


def inverse_stereographic_projection(uv: FloatArray) -> FloatArray:
    """Inverse of :func:`stereographic_projection`.

    Parameters
    ----------
    uv : (n, 2) float64
        Points of the plane. Not modified.

    Returns
    -------
    P : (n, 3) float64
        ``(2u, 2v, 1 − r²) / (1 + r²)`` on the unit sphere.
    """
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ValueError(f"uv must have shape (n, 2), got {uv.shape}")
    r2 = (uv**2).sum(axis=1)
    return np.column_stack([2 * uv[:, 0], 2 * uv[:, 1], 1.0 - r2]) / (1.0 + r2)[:, None]


def equator_rotation(P_boundary: FloatArray, P_inside: FloatArray) -> FloatArray:
    """Rotation taking the great circle nearest the boundary images to the equator.

    Parameters
    ----------
    P_boundary : (k, 3) float64
        Images of the boundary loop on the sphere.
    P_inside : (p, 3) float64
        Images of the points that must end up north of the equator.

    Returns
    -------
    R : (3, 3) float64
        A proper rotation; ``P @ R.T`` has the least-squares plane through the
        origin of ``P_boundary`` as its equator, and the mean of
        ``P_inside @ R.T`` has positive z.

    Notes
    -----
    The plane's normal is the right singular vector of ``P_boundary`` with
    the smallest singular value. When the boundary already lies on a great
    circle (the symmetric double-cover flow keeps it there to round-off) the
    rotation is exact.
    """
    _, _, Wt = np.linalg.svd(P_boundary, full_matrices=False)
    nrm = Wt[-1]
    if P_inside.size and float((P_inside @ nrm).mean()) < 0:
        nrm = -nrm
    # rotation taking nrm to e_z (Rodrigues), with the antipodal case handled
    ez = np.array([0.0, 0.0, 1.0])
    c = float(nrm @ ez)
    if c < -1 + 1e-15:
        return np.diag([1.0, -1.0, -1.0])
    v = np.cross(nrm, ez)
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


def hemisphere_to_disk(phi: FloatArray, F: IntArray, b: IntArray) -> FloatArray:
    """Cut the sphere at the boundary's great circle and project the map's half to the plane.

    Parameters
    ----------
    phi : (n, 3) float64
        Spherical images of a disk mesh's vertices (the first copy of a
        double cover). Not modified.
    F : (m, 3) int64
        The disk mesh's triangles.
    b : (k,) int64
        Its boundary loop.

    Returns
    -------
    uv : (n, 2) float64
        :func:`stereographic_projection` of the rotated images
        (:func:`equator_rotation`), reflected if needed so that the triangles
        are counter-clockwise (positive total signed area). The boundary lies
        on the unit circle only as exactly as it lay on a great circle: use
        :func:`normalize_boundary_to_circle` next.
    """
    inside = np.ones(phi.shape[0], dtype=bool)
    inside[b] = False
    R = equator_rotation(phi[b], phi[inside])
    uv = stereographic_projection(phi @ R.T)
    if signed_areas_2d(uv, F).sum() < 0:
        uv[:, 1] = -uv[:, 1]
    return uv


def normalize_boundary_to_circle(
    V: FloatArray,
    F: IntArray,
    uv: FloatArray,
    b: IntArray,
    *,
    laplacian: sp.csr_array | None = None,
    interior_factor: Factorization | None = None,
) -> FloatArray:
    """Put the boundary exactly on the unit circle and re-extend the interior harmonically.

    Parameters
    ----------
    V : (n, 3) float64
        The surface. Not modified.
    F : (m, 3) int64
        Its triangles.
    uv : (n, 2) float64
        A nearly conformal disk map whose boundary is nearly the unit circle.
        Not modified.
    b : (k,) int64
        Boundary loop.
    laplacian : (n, n) csr_array, optional
        ``cotangent_laplacian(V, F)``, if already at hand.
    interior_factor : Factorization, optional
        Factorisation of ``L[I][:, I]`` for the interior vertices ``I`` in
        increasing order, if already at hand (it is reused, not recomputed).

    Returns
    -------
    uv : (n, 2) float64
        Boundary vertices at ``uv_b / |uv_b|`` (their angles kept), interior
        vertices the discrete harmonic extension ``L_II uv_I = −L_IB uv_B``
        with the surface's cotangent Laplacian.

    Notes
    -----
    A conformal map onto the disk is harmonic, so it is the harmonic
    extension of its own boundary values: keeping the projected boundary
    correspondence and re-solving the interior restores an exactly circular
    boundary without moving the interior away from conformality. On
    ``choi_human_face`` this gave 1.2131° mean angle distortion where the
    bare radial snap of the boundary gave 1.2133°
    (``benchmarks/bench_qiem.py``).
    """
    n = uv.shape[0]
    z = uv[b, 0] + 1j * uv[b, 1]
    r = np.abs(z)
    if np.any(r == 0):
        raise ValueError("a boundary vertex was mapped to the origin")
    z = z / r
    out = np.zeros((n, 2))
    out[b, 0] = z.real
    out[b, 1] = z.imag
    interior = np.ones(n, dtype=bool)
    interior[b] = False
    inner = np.flatnonzero(interior)
    if inner.size:
        L = sp.csr_array(cotangent_laplacian(V, F) if laplacian is None else laplacian)
        fac = interior_factor
        if fac is None:
            fac = factorize(L[inner][:, inner], symmetric=True)
        out[inner] = fac.solve(-(L[inner][:, b] @ out[b]))
    return out
