"""Beltrami coefficient of a piecewise-linear map between a surface and the plane."""

from __future__ import annotations

import numpy as np

from ._typing import ComplexArray, FloatArray, IntArray


def triangle_frames(V: FloatArray, F: IntArray) -> FloatArray:
    """Each triangle in its own isometric, orientation-preserving 2D frame.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Returns
    -------
    X : (m, 3, 2) float64
        Corner coordinates: corner 0 at the origin, corner 1 on the positive
        x axis, corner 2 in the upper half plane (so every non-degenerate
        triangle is counter-clockwise in its frame).
    """
    p0, p1, p2 = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    e1 = p1 - p0
    e2 = p2 - p0
    l1 = np.linalg.norm(e1, axis=1)
    x2 = np.einsum("ij,ij->i", e2, e1) / l1
    y2 = np.linalg.norm(np.cross(e1, e2), axis=1) / l1
    X = np.zeros((F.shape[0], 3, 2))
    X[:, 1, 0] = l1
    X[:, 2, 0] = x2
    X[:, 2, 1] = y2
    return X


def beltrami_coefficient(V: FloatArray, F: IntArray, uv: FloatArray) -> ComplexArray:
    """Per-triangle Beltrami coefficient μ of the map from the disk to the surface.

    Parameters
    ----------
    V : (n, 3) float64
        Surface vertices. Not modified.
    F : (m, 3) int64
        Triangles.
    uv : (n, 2) float64
        Parameterisation (e.g. a disk map). Not modified.

    Returns
    -------
    mu : (m,) complex128
        ``μ = g_z̄ / g_z`` of the affine map ``g`` from each uv triangle (with
        ``z = u + i v``) to the 3D triangle expressed in its isometric frame
        (:func:`triangle_frames`). μ does not depend on that frame's
        rotation, since both ``g_z`` and ``g_z̄`` turn with it. ``|μ|`` equals
        the Beltrami coefficient's modulus of the inverse map, surface → disk:
        0 for a conformal (similarity) triangle, below 1 for an
        orientation-preserving one, above 1 for a flipped one, ``inf`` when
        the 3D triangle is degenerate and ``nan`` when both are.

    Notes
    -----
    With ``g(z) = X0 + J (z − z0)``, ``J = [[a, b], [c, d]]`` (a = ∂x/∂u,
    b = ∂x/∂v, c = ∂y/∂u, d = ∂y/∂v)::

        g_z = ((a + d) + i (c − b)) / 2,   g_z̄ = ((a − d) + i (c + b)) / 2.

    References
    ----------
    L. V. Ahlfors, *Lectures on Quasiconformal Mappings*, 2nd ed., AMS (2006);
    P. T. Choi, K. C. Lam, L. M. Lui, "FLASH: Fast landmark aligned spherical
    harmonic parameterization for genus-0 closed brain surfaces", SIAM J.
    Imaging Sci. 8(1) (2015), doi:10.1137/130950008 (the per-triangle
    discretisation).

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> F = np.array([[0, 1, 2]])
    >>> float(abs(beltrami_coefficient(V, F, np.array([[0., 0], [2, 0], [0, 1]]))[0]).round(12))
    0.333333333333
    """
    V = np.asarray(V, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V must have shape (n, 3), got {V.shape}")
    if uv.shape != (V.shape[0], 2):
        raise ValueError(f"uv must have shape ({V.shape[0]}, 2), got {uv.shape}")
    if F.ndim != 2 or F.shape[1] != 3:
        raise ValueError(f"F must have shape (m, 3), got {F.shape}")
    X = triangle_frames(V, F)
    U = uv[F]
    # columns of the uv edge matrix and of the frame edge matrix
    du1 = U[:, 1] - U[:, 0]
    du2 = U[:, 2] - U[:, 0]
    dx1 = X[:, 1] - X[:, 0]
    dx2 = X[:, 2] - X[:, 0]
    det = du1[:, 0] * du2[:, 1] - du1[:, 1] * du2[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        # J = [dx1 dx2] @ inv([du1 du2])
        inv = (
            np.stack(
                [
                    np.stack([du2[:, 1], -du2[:, 0]], axis=1),
                    np.stack([-du1[:, 1], du1[:, 0]], axis=1),
                ],
                axis=1,
            )
            / det[:, None, None]
        )
        D = np.stack([dx1, dx2], axis=2)  # (m, 2, 2): columns dx1, dx2
        J = D @ inv
        a, b = J[:, 0, 0], J[:, 0, 1]
        c, d = J[:, 1, 0], J[:, 1, 1]
        gz = 0.5 * ((a + d) + 1j * (c - b))
        gzb = 0.5 * ((a - d) + 1j * (c + b))
        mu = gzb / gz
    return np.asarray(mu, dtype=np.complex128)
