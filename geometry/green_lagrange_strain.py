"""Green–Lagrange strain of a piecewise-linear 2D deformation, and its interpolation in time.

The strain is measured per triangle (linear elements have a constant
deformation gradient), in the axes of the *rest* (source) configuration,
exactly as eq. (1) of Yan, Hu and Martin (2004).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from ._typing import FloatArray, IntArray
from .mesh_errors import NotTrianglesError, ZeroAreaFaceError
from .tolerances import ZERO_AREA_RTOL

StrainScheme = Literal["modified", "linear", "principal"]


def _check_planar(V: FloatArray, F: IntArray, name: str) -> tuple[FloatArray, IntArray]:
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 2:
        raise NotTrianglesError(f"{name} must have shape (n, 2), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] == 0:
        raise NotTrianglesError(f"F must have shape (m, 3) with m > 0, got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise NotTrianglesError(f"F must be an integer array, got dtype {F.dtype}")
    if F.min() < 0 or F.max() >= V.shape[0]:
        raise NotTrianglesError(
            f"face indices must lie in [0, {V.shape[0]}), got [{F.min()}, {F.max()}]"
        )
    if not np.all(np.isfinite(V)):
        raise ValueError(f"{name} has non-finite coordinates")
    return V, F.astype(np.int64)


def signed_areas(V: FloatArray, F: IntArray) -> FloatArray:
    """Signed areas of planar triangles (positive when counter-clockwise).

    Parameters
    ----------
    V : (n, 2) float64
        Vertex positions.
    F : (m, 3) int64
        Triangles.

    Returns
    -------
    area : (m,) float64
        ``((v1 - v0) × (v2 - v0)) / 2``.

    Examples
    --------
    >>> import numpy as np
    >>> float(signed_areas(np.array([[0.0, 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]]))[0])
    0.5
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    e1 = V[F[:, 1]] - V[F[:, 0]]
    e2 = V[F[:, 2]] - V[F[:, 0]]
    return np.asarray(0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]), dtype=np.float64)


def shape_function_gradients(rest_V: FloatArray, F: IntArray) -> tuple[FloatArray, FloatArray]:
    """Gradients of the linear shape functions (barycentric coordinates) of each triangle.

    Parameters
    ----------
    rest_V : (n, 2) float64
        Rest (source) positions.
    F : (m, 3) int64
        Triangles, counter-clockwise in ``rest_V``.

    Returns
    -------
    dN : (m, 3, 2) float64
        ``dN[f, k] = (∂N_k/∂x, ∂N_k/∂y)`` on triangle f; ``dN[f].sum(0) = 0``.
    area : (m,) float64
        Rest areas, all positive.

    Raises
    ------
    ZeroAreaFaceError
        If a rest triangle has an area below ``ZERO_AREA_RTOL`` times the mean
        area, or is clockwise.
    """
    rest_V, F = _check_planar(rest_V, F, "rest_V")
    area = signed_areas(rest_V, F)
    scale = float(np.abs(area).mean())
    bad = area <= ZERO_AREA_RTOL * scale
    if scale == 0.0 or np.any(bad):
        raise ZeroAreaFaceError(
            f"{int(bad.sum())} of {F.shape[0]} rest triangles have zero or negative area "
            f"(expected counter-clockwise triangles of positive area)"
        )
    dN = np.zeros((F.shape[0], 3, 2))
    for k in range(3):
        # ∇N_k is the inward normal of the opposite edge divided by twice the area.
        p = rest_V[F[:, (k + 1) % 3]]
        q = rest_V[F[:, (k + 2) % 3]]
        e = q - p
        dN[:, k, 0] = -e[:, 1] / (2.0 * area)
        dN[:, k, 1] = e[:, 0] / (2.0 * area)
    return dN, area


def deformation_gradient(dN: FloatArray, V: FloatArray, F: IntArray) -> FloatArray:
    """Deformation gradient of the piecewise-linear map rest → ``V``.

    Parameters
    ----------
    dN : (m, 3, 2) float64
        Shape-function gradients from :func:`shape_function_gradients`.
    V : (n, 2) float64
        Deformed positions.
    F : (m, 3) int64
        Triangles.

    Returns
    -------
    J : (m, 2, 2) float64
        ``J[f, a, b] = ∂x'_a / ∂x_b`` (eq. 5 differentiated).
    """
    V = np.asarray(V, dtype=np.float64)
    x, y = V[:, 0][F], V[:, 1][F]  # (m, 3) each
    dx, dy = dN[:, :, 0], dN[:, :, 1]
    # J[a, b] = Σ_k x'_{k,a} ∂N_k/∂x_b, written out (einsum costs ~5× more at this size)
    J = np.zeros((F.shape[0], 2, 2))
    J[:, 0, 0] = x[:, 0] * dx[:, 0] + x[:, 1] * dx[:, 1] + x[:, 2] * dx[:, 2]
    J[:, 0, 1] = x[:, 0] * dy[:, 0] + x[:, 1] * dy[:, 1] + x[:, 2] * dy[:, 2]
    J[:, 1, 0] = y[:, 0] * dx[:, 0] + y[:, 1] * dx[:, 1] + y[:, 2] * dx[:, 2]
    J[:, 1, 1] = y[:, 0] * dy[:, 0] + y[:, 1] * dy[:, 1] + y[:, 2] * dy[:, 2]
    return J


def strain_from_gradient(J: FloatArray) -> FloatArray:
    """Green–Lagrange strain components from deformation gradients (eq. 1).

    Parameters
    ----------
    J : (m, 2, 2) float64
        Deformation gradients.

    Returns
    -------
    eps : (m, 3) float64
        ``[ε_x, ε_y, γ_xy]`` per triangle: ``ε_x = (|J e_x|² - 1)/2``,
        ``ε_y = (|J e_y|² - 1)/2``, ``γ_xy = (J e_x)·(J e_y)`` (engineering shear,
        twice the tensor component E_xy).
    """
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    eps = np.zeros((J.shape[0], 3))
    eps[:, 0] = 0.5 * (a * a + c * c - 1.0)
    eps[:, 1] = 0.5 * (b * b + d * d - 1.0)
    eps[:, 2] = a * b + c * d
    return eps


def green_lagrange_strain(rest_V: FloatArray, V: FloatArray, F: IntArray) -> FloatArray:
    """Per-triangle Green–Lagrange strain of the deformation ``rest_V`` → ``V`` (eq. 1).

    Parameters
    ----------
    rest_V : (n, 2) float64
        Rest positions; the strain is expressed in these axes.
    V : (n, 2) float64
        Deformed positions (same connectivity).
    F : (m, 3) int64
        Triangles, counter-clockwise in ``rest_V``.

    Returns
    -------
    eps : (m, 3) float64
        ``[ε_x, ε_y, γ_xy]`` per triangle.

    Notes
    -----
    Invariant under rigid motions of ``V`` (it depends on JᵀJ only); a
    rotation of ``rest_V`` mixes the components like a tensor.

    References
    ----------
    H.-B. Yan, S.-M. Hu, R. R. Martin, "Morphing based on strain field
    interpolation", Computer Animation and Virtual Worlds 15 (2004) 443–452,
    doi:10.1002/cav.48.

    Examples
    --------
    >>> import numpy as np
    >>> R = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> green_lagrange_strain(R, 2 * R, np.array([[0, 1, 2]])).round(12).tolist()
    [[1.5, 1.5, 0.0]]
    """
    rest_V, F = _check_planar(rest_V, F, "rest_V")
    V, _ = _check_planar(V, F, "V")
    if V.shape != rest_V.shape:
        raise ValueError(f"V has shape {V.shape}, rest_V has shape {rest_V.shape}")
    dN, _area = shape_function_gradients(rest_V, F)
    return strain_from_gradient(deformation_gradient(dN, V, F))


def _principal_stretch_interpolation(target_eps: FloatArray, t: float) -> FloatArray:
    """Eq. (3) applied in each triangle's principal frame: U_t = (1 − t) I + t U, ε_t = (U_t² − I)/2.

    U = sqrt(I + 2 ε^n) is the right stretch tensor. In the principal axes of
    ε^n the shear is zero and eq. (3) makes both principal stretches linear in
    t; unlike eq. (3) in the fixed x/y frame this does not depend on the
    orientation of the axes, and C_t = U_t² is always positive definite.
    """
    C11 = 1.0 + 2.0 * target_eps[:, 0]
    C22 = 1.0 + 2.0 * target_eps[:, 1]
    C12 = target_eps[:, 2]
    sdet = np.sqrt(np.maximum(C11 * C22 - C12**2, 0.0))
    den = np.sqrt(np.maximum(C11 + C22 + 2.0 * sdet, 1e-300))
    U11, U22, U12 = (C11 + sdet) / den, (C22 + sdet) / den, C12 / den
    A11, A22, A12 = (1 - t) + t * U11, (1 - t) + t * U22, t * U12
    out = np.empty_like(target_eps)
    out[:, 0] = 0.5 * (A11**2 + A12**2 - 1.0)
    out[:, 1] = 0.5 * (A22**2 + A12**2 - 1.0)
    out[:, 2] = A12 * (A11 + A22)
    return out


def interpolate_strain(
    target_eps: FloatArray, t: float, *, scheme: StrainScheme = "modified"
) -> FloatArray:
    """Desired strain at time ``t`` between the rest state (zero strain) and ``target_eps``.

    Parameters
    ----------
    target_eps : (m, 3) float64
        Strain ``ε^n`` of the final frame, ``[ε_x, ε_y, γ_xy]`` per triangle.
    t : float
        Time in [0, 1].
    scheme : {"modified", "linear", "principal"}
        ``"linear"``: ``ε^t = t ε^n`` (eq. 2); ``"modified"``: eq. (3), which
        makes the stretches ``sqrt(1 + 2 ε)`` of the x and y line elements
        linear in t and interpolates the shear through ``tan(t arctan γ)``;
        ``"principal"``: eq. (3) in each triangle's principal strain frame
        (no shear there), i.e. the right stretch tensor ``U_t = (1 − t) I + t U``
        — frame independent, always a realisable strain. Eq. (3) in the fixed
        x/y frame is not: with shears |γ| ≫ 1 (I → L stretches triangles
        tenfold along a diagonal) ``tan(t arctan γ)`` stays near 0 until t ≈ 0.9
        while the stretches grow linearly, and the strain morph's path of
        minimisers folds a triangle (measured, ``benchmarks/bench_morph2d.py``).

    Returns
    -------
    eps : (m, 3) float64

    Notes
    -----
    The paper prints eq. (2) as ``(1 - t) ε^n``; with ``t = 0`` the source and
    ``t = 1`` the target (as the paper defines them, and as eq. 3 implies)
    the consistent linear scheme is ``t ε^n``, used here.

    Examples
    --------
    >>> import numpy as np
    >>> e = np.array([[1.5, 0.0, 0.0]])  # x stretch 2
    >>> interpolate_strain(e, 0.5).tolist()  # stretch 1.5
    [[0.625, 0.0, 0.0]]
    """
    target_eps = np.asarray(target_eps, dtype=np.float64)
    if target_eps.ndim != 2 or target_eps.shape[1] != 3:
        raise ValueError(f"target_eps must have shape (m, 3), got {target_eps.shape}")
    if not 0.0 <= t <= 1.0:
        raise ValueError(f"t must lie in [0, 1], got {t}")
    if scheme == "linear":
        return np.asarray(t * target_eps, dtype=np.float64)
    if scheme == "principal":
        return _principal_stretch_interpolation(target_eps, t)
    if scheme != "modified":
        raise ValueError(f"scheme must be 'modified', 'linear' or 'principal', got {scheme!r}")
    out = np.zeros_like(target_eps)
    for c in (0, 1):
        # 1 + 2ε = |J e|² ≥ 0; clip round-off below zero.
        stretch = np.sqrt(np.maximum(1.0 + 2.0 * target_eps[:, c], 0.0))
        out[:, c] = 0.5 * ((t * stretch + (1.0 - t)) ** 2 - 1.0)
    out[:, 2] = np.tan(t * np.arctan(target_eps[:, 2]))
    return out
