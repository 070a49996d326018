"""As-rigid-as-possible shape interpolation (Alexa, Cohen-Or and Levin 2000), the 2D baseline."""

from __future__ import annotations

from collections import deque

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .green_lagrange_strain import deformation_gradient, shape_function_gradients
from .sparse_factor import factorize


def _consistent_angles(theta: FloatArray, F: IntArray) -> FloatArray:
    """Shift per-triangle rotation angles by multiples of 2π to agree with their neighbours.

    Breadth-first over the dual graph from triangle 0 of each component, each
    triangle takes the representative of its angle nearest its parent's, so a
    shape that turns by more than π along its length (a coiled bar) keeps one
    continuous rotation field instead of jumping by 2π between triangles.
    """
    m = F.shape[0]
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    face = np.tile(np.arange(m), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    e, f = edges[order], face[order]
    same = np.all(e[1:] == e[:-1], axis=1)
    pairs = np.stack([f[:-1][same], f[1:][same]], axis=1)
    adj: list[list[int]] = [[] for _ in range(m)]
    for p, q in pairs:
        adj[int(p)].append(int(q))
        adj[int(q)].append(int(p))
    out = theta.copy()
    seen = np.zeros(m, dtype=bool)
    for root in range(m):
        if seen[root]:
            continue
        seen[root] = True
        queue = deque([root])
        while queue:
            p = queue.popleft()
            for q in adj[p]:
                if not seen[q]:
                    out[q] += 2.0 * np.pi * np.round((out[p] - out[q]) / (2.0 * np.pi))
                    seen[q] = True
                    queue.append(q)
    return out


def arap_interpolation(
    source_V: FloatArray,
    target_V: FloatArray,
    F: IntArray,
    times: FloatArray,
    *,
    fixed_vertex: int | None = None,
) -> FloatArray:
    """As-rigid-as-possible interpolation between two compatible planar meshes.

    Parameters
    ----------
    source_V : (n, 2) float64
        Source positions (t = 0).
    target_V : (n, 2) float64
        Target positions (t = 1), vertex i ↔ vertex i.
    F : (m, 3) int64
        Shared triangles, counter-clockwise in ``source_V``.
    times : (T,) float64
        Times in [0, 1].
    fixed_vertex : int, optional
        The vertex whose position is interpolated linearly (fixing the
        translation); default: the vertex nearest the source centroid.

    Returns
    -------
    frames : (T, n, 2) float64
        Vertex positions per time.

    Notes
    -----
    Each triangle's affine map source → target has linear part
    ``A = R_θ S`` (polar decomposition; S symmetric positive definite, θ made
    continuous across neighbouring triangles). Its interpolant is
    ``A(t) = R_{tθ} ((1 − t) I + t S)``, and the frame minimises
    ``Σ_f area_f ‖J_f(V) − A_f(t)‖_F²`` over V with the fixed vertex at its
    linearly interpolated position. The normal equations have the (constant)
    cotangent-Laplacian matrix, factorised once for all frames. Frames at
    t = 0 and t = 1 reproduce the two meshes.

    References
    ----------
    M. Alexa, D. Cohen-Or, D. Levin, "As-rigid-as-possible shape
    interpolation", Proc. SIGGRAPH 2000, 157–164, doi:10.1145/344779.344859.
    """
    source_V = np.asarray(source_V, dtype=np.float64)
    target_V = np.asarray(target_V, dtype=np.float64)
    if target_V.shape != source_V.shape:
        raise ValueError(f"target_V has shape {target_V.shape}, expected {source_V.shape}")
    times = np.asarray(times, dtype=np.float64).reshape(-1)
    if times.size == 0 or times.min() < 0.0 or times.max() > 1.0:
        raise ValueError("times must be a non-empty sequence in [0, 1]")
    dN, area = shape_function_gradients(source_V, F)
    F = np.asarray(F, dtype=np.int64)
    n = source_V.shape[0]
    A = deformation_gradient(dN, target_V, F)
    if np.any(np.linalg.det(A) <= 0):
        raise ValueError("target_V has flipped or degenerate triangles: meshes are not compatible")
    theta = np.arctan2(A[:, 1, 0] - A[:, 0, 1], A[:, 0, 0] + A[:, 1, 1])
    c, s = np.cos(theta), np.sin(theta)
    Rt = np.stack([np.stack([c, s], -1), np.stack([-s, c], -1)], 1)  # Rᵀ
    S = np.einsum("fab,fbc->fac", Rt, A)
    S = 0.5 * (S + np.transpose(S, (0, 2, 1)))
    theta = _consistent_angles(theta, F)

    if fixed_vertex is None:
        fixed_vertex = int(np.argmin(np.linalg.norm(source_V - source_V.mean(0), axis=1)))
    if not 0 <= fixed_vertex < n:
        raise ValueError(f"fixed_vertex must lie in [0, {n}), got {fixed_vertex}")
    # L = Σ_f area_f dN_f dN_fᵀ (the cotangent Laplacian, PSD), grounded at the fixed vertex
    local = area[:, None, None] * np.einsum("fka,fla->fkl", dN, dN)
    rows = np.repeat(F, 3, axis=1).ravel()
    cols = np.tile(F, (1, 3)).ravel()
    L = sp.coo_array((local.ravel(), (rows, cols)), shape=(n, n)).tocsr()
    free = np.ones(n, dtype=bool)
    free[fixed_vertex] = False
    Lff = sp.csc_array(L[free][:, free])
    Lfc = L[free][:, [fixed_vertex]]
    factor = factorize(Lff, symmetric=True)

    eye = np.eye(2)
    frames = np.zeros((times.shape[0], n, 2))
    for i, t in enumerate(times):
        ct, st = np.cos(t * theta), np.sin(t * theta)
        Rt_ = np.stack([np.stack([ct, -st], -1), np.stack([st, ct], -1)], 1)
        At = np.einsum("fab,fbc->fac", Rt_, (1.0 - t) * eye + t * S)
        # rhs_i = Σ_{f ∋ i} area_f A_f(t) ∇N_{f,k}
        g = area[:, None, None] * np.einsum("fab,fkb->fka", At, dN)
        rhs = np.zeros((n, 2))
        np.add.at(rhs, F.ravel(), g.reshape(-1, 2))
        p = (1.0 - t) * source_V[fixed_vertex] + t * target_V[fixed_vertex]
        frames[i, fixed_vertex] = p
        frames[i, free] = factor.solve(rhs[free] - Lfc @ p[None, :])
    return frames
