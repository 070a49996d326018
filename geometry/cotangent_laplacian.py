"""Cotangent Laplacian of a triangle mesh (the one place that fixes its sign)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .mesh_edges import MeshEdges, mesh_edges


def cotangent_weights(V: FloatArray, F: IntArray) -> FloatArray:
    """Half-cotangents of the three corner angles of every triangle.

    Parameters
    ----------
    V : (n, d) float64
        Vertex positions, d = 2 or 3.
    F : (m, 3) int64
        Triangles.

    Returns
    -------
    C : (m, 3) float64
        ``C[f, k] = cot(angle at corner k of f) / 2``; this is the weight of
        the edge opposite corner k, i.e. of edge (F[f, k+1], F[f, k+2]).

    Notes
    -----
    cot θ = (a·b) / |a × b| for the two edge vectors a, b at the corner; for
    d = 2 the cross product is the scalar z component.
    """
    P = [V[F[:, k]] for k in range(3)]
    # |a x b| is twice the triangle's area at every corner: computed once
    e1, e2 = P[1] - P[0], P[2] - P[0]
    if V.shape[1] == 2:
        cross = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    else:
        cross = np.linalg.norm(np.cross(e1, e2), axis=1)
    C = np.zeros((F.shape[0], 3))
    for k in range(3):
        a = P[(k + 1) % 3] - P[k]
        b = P[(k + 2) % 3] - P[k]
        C[:, k] = 0.5 * np.einsum("ij,ij->i", a, b) / cross
    return C


def cotangent_laplacian(V: FloatArray, F: IntArray, E: MeshEdges | None = None) -> sp.csr_array:
    """Cotangent Laplacian, **positive semi-definite** convention.

    Parameters
    ----------
    V : (n, d) float64
        Vertex positions (d = 2 for a parameterisation, 3 for a surface).
    F : (m, 3) int64
        Triangles.
    E : MeshEdges, optional
        ``mesh_edges(F)``, if the caller already has it.

    Returns
    -------
    L : (n, n) csr_array, float64
        ``L[i, j] = -(cot α_ij + cot β_ij) / 2`` for an edge ij,
        ``L[i, i] = -Σ_j L[i, j]``. Symmetric, ``L @ 1 = 0``, and positive
        semi-definite whenever all weights are positive (Delaunay meshes).
        ``(L @ V)[i]`` is the integrated mean-curvature normal
        ``2 H_i A_i n_i`` (Meyer et al. 2003, eq. 8) with ``n`` pointing to
        the convex side: ``L V = -ΔV`` integrated over vertex areas.

    Examples
    --------
    One right isosceles triangle: the hypotenuse's opposite angle is 90°
    (cot = 0) and the legs' opposite angles are 45° (cot = 1).

    >>> import numpy as np
    >>> L = cotangent_laplacian(np.array([[0., 0], [1, 0], [0, 1]]), np.array([[0, 1, 2]]))
    >>> L.toarray()
    array([[ 1. , -0.5, -0.5],
           [-0.5,  0.5,  0. ],
           [-0.5,  0. ,  0.5]])

    References
    ----------
    M. Meyer, M. Desbrun, P. Schröder, A. H. Barr, "Discrete
    Differential-Geometry Operators for Triangulated 2-Manifolds",
    Visualization and Mathematics III (2003), doi:10.1007/978-3-662-05105-4_2.
    """
    n = V.shape[0]
    E = mesh_edges(F) if E is None else E
    C = cotangent_weights(V, F)
    # half-edge (F[f,k], F[f,k+1]) is opposite corner k+2
    w = np.bincount(
        E.halfedge_edge.reshape(-1), weights=np.roll(C, -2, axis=1).reshape(-1), minlength=E.edges.shape[0]
    )
    i, j = E.edges[:, 0], E.edges[:, 1]
    diag = np.bincount(i, weights=w, minlength=n) + np.bincount(j, weights=w, minlength=n)
    rows = np.concatenate([i, j, np.arange(n)])
    cols = np.concatenate([j, i, np.arange(n)])
    vals = np.concatenate([-w, -w, diag])
    return sp.csr_array((vals, (rows, cols)), shape=(n, n))
