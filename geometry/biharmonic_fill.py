"""Values of some vertices solved from the others by the (uniform) bi-Laplacian: the smooth
fill of a hole patch, for positions and for any per-vertex attribute."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .sparse_factor import factorize


def uniform_laplacian(F: IntArray, n: int) -> sp.csr_array:
    """Graph Laplacian ``D - A`` of the edges of ``F`` (positive semi-definite).

    Parameters
    ----------
    F : (m, 3) int64
    n : int
        Vertex count.

    Returns
    -------
    L : (n, n) csr_array
        ``L[i, i]`` is the number of neighbours of ``i``, ``L[i, j] = -1``
        for every edge ``ij``; ``L @ 1 = 0``.
    """
    he = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    key = np.unique(np.sort(he, axis=1) @ np.array([n, 1], dtype=np.int64))
    i, j = np.divmod(key, n)
    A = sp.coo_array((np.ones(key.size), (i, j)), shape=(n, n)).tocsr()
    A = A + A.T
    deg = np.asarray(A.sum(axis=1)).ravel()
    return sp.csr_array(sp.diags_array(deg) - A)


def biharmonic_fill(F: IntArray, values: FloatArray, unknown: IntArray) -> FloatArray:
    """Solve the rows ``unknown`` of ``values`` from the others by ``(L²) x = 0`` on them.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles of the whole mesh (the hole patches included).
    values : (n, d) float64
        Per-vertex values; the rows ``unknown`` are ignored (initial guesses
        are not needed: the system is solved directly).
    unknown : (u,) int64
        Distinct vertex indices to solve for.

    Returns
    -------
    out : (n, d) float64
        ``values`` with the rows ``unknown`` replaced by the solution of
        ``(L²)[u, u] x_u = -(L²)[u, k] x_k`` for the uniform Laplacian ``L``
        (:func:`uniform_laplacian`), ``k`` every other vertex. The input is
        not modified.

    Raises
    ------
    ValueError
        Shapes disagree, indices are out of range or repeated, no vertex is
        known, or the known values are not finite.
    SingularSystemError
        When an unknown vertex is not connected to any known one.

    Notes
    -----
    The bi-Laplacian minimises ``Σ |L x|²`` over the unknowns, so the patch
    continues the position *and* the slope of the surface around it (its
    stencil reaches two rings out: the hole's loop and the ring beyond),
    where a harmonic fill would only meet the loop. It is linear, so
    texture coordinates and colours are filled the same way as positions.
    A plane is reproduced exactly when the patch's own connectivity is
    regular; in general the fill lies in the plane of a planar surround.

    Examples
    --------
    A square of four triangles around a centre 4; the centre of a flat
    square lands in its plane:

    >>> F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    >>> P = np.array([[0.0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1], [9, 9, 9]])
    >>> np.round(biharmonic_fill(F, P, np.array([4])), 6)[4].tolist()
    [0.5, 0.5, 1.0]
    """
    values = np.asarray(values, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    unknown = np.asarray(unknown, dtype=np.int64)
    if values.ndim != 2:
        raise ValueError(f"values must be an (n, d) array, got {values.shape}")
    n = values.shape[0]
    if F.ndim != 2 or F.shape[1] != 3 or F.size == 0 or F.min() < 0 or F.max() >= n:
        raise ValueError(f"F must be (m, 3) indices into the {n} rows of values")
    if unknown.ndim != 1 or (unknown.size and (unknown.min() < 0 or unknown.max() >= n)):
        raise ValueError(f"unknown must be vertex indices in 0..{n - 1}")
    if np.unique(unknown).size != unknown.size:
        raise ValueError("unknown repeats vertex indices")
    out = values.copy()
    if unknown.size == 0:
        return out
    known = np.ones(n, dtype=bool)
    known[unknown] = False
    if not known.any():
        raise ValueError("every vertex is unknown: the fill needs known values around it")
    if not np.all(np.isfinite(values[known])):
        raise ValueError("the known rows of values must be finite")
    L = uniform_laplacian(F, n)
    L2u = sp.csc_array(L[unknown, :] @ L)  # rows of L² at the unknowns
    A = L2u[:, unknown]
    rhs = -(L2u[:, np.flatnonzero(known)] @ values[known])
    out[unknown] = factorize(A, symmetric=True).solve(rhs)
    return out
