"""Discrete mean curvature (cotangent formula), scalar and vector."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .boundary_loop import boundary_loops
from .cotangent_laplacian import cotangent_laplacian
from .vertex_areas import vertex_areas
from .vertex_normals import vertex_normals


def mean_curvature_vector(V: FloatArray, F: IntArray) -> FloatArray:
    """Mean-curvature vector ``H n`` per vertex (Meyer et al. 2003).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Returns
    -------
    Hn : (n, 3) float64
        ``(L V)_i / (2 A_i)`` with ``L`` the cotangent Laplacian and ``A_i``
        the barycentric vertex area. On irregular meshes this vector has a
        tangential part; keeping it makes reconstruction from it exact up to
        the change of Laplacian (see :func:`conformorph.geometry.reconstruct_surface`).
        Boundary rows are not curvature (they carry the boundary's geodesic
        curvature) and are set to 0.
    """
    L = cotangent_laplacian(V, F)
    Hn = (L @ V) / (2.0 * vertex_areas(V, F))[:, None]
    for loop in boundary_loops(F):
        Hn[loop] = 0.0
    return Hn


def mean_curvature(V: FloatArray, F: IntArray) -> FloatArray:
    """Signed scalar mean curvature per vertex, section 2.3 of the face paper.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Returns
    -------
    H : (n,) float64
        ``H_i = |H n|_i`` signed by the area-weighted vertex normal
        (positive where the surface bends away from its normal, e.g. a
        sphere with outward faces has H = 1/r). 0 on the boundary.

    Notes
    -----
    The paper's formula divides by ``4 Area(N1(x_i))``, the area of the
    whole one-ring, which is three times the barycentric vertex area used
    here; that makes its H a third of the mean curvature. We use the
    barycentric area so that H is the mean curvature itself (1/r on a
    sphere); reconstruction uses the same convention, so nothing depends on
    the choice. The magnitude of the full vector (not its normal component)
    is kept, so that ``H`` times the mean-curvature direction reproduces the
    vector exactly.
    """
    Hn = mean_curvature_vector(V, F)
    s = np.sign(np.einsum("ij,ij->i", Hn, vertex_normals(V, F)))
    s[s == 0] = 1.0
    return s * np.linalg.norm(Hn, axis=1)
