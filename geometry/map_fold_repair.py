"""Local repair of a planar piecewise-linear map that folds a few triangles.

A registration of the disk must be a bijection (section 3 of the face paper), and
composing several fold-free steps can still fold a triangle or two where the steps'
rounding meets a sliver (issue 27: "folds 1 of the 7120 consistent-mesh triangles").
Refusing the whole morph for that is refusing a clean face for a local defect. Here
the map is re-solved around the folds only: the images of the vertices within ``r``
rings of the folded triangles are replaced by the solution of the source's
mean-value equations (Floater's weights, positive on every edge)

.. math::

    \\sum_j w_{ij} (y_i - y_j) = 0 \\quad \\text{for every re-solved vertex } i,

with every other vertex kept where the map put it. Mean-value coordinates reproduce
affine maps exactly, so where the map is locally affine the re-solve changes nothing;
by Floater's theorem the re-solved patch is an embedding when its fixed rim is a
convex polygon in the image, and nearly always when it is star-shaped. The region
grows ring by ring (``max_rings``) until no triangle folds anywhere. Vertices marked
``fixed`` (the disk's boundary, which stays on the unit circle) never move.

A careful reading of "repair" chooses the smallest region that works, since every
moved vertex changes the correspondence; the displacement is returned so that the
caller reports how far the map moved.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ._typing import BoolArray, FloatArray, IntArray
from .map_jacobian import fold_report
from .mean_value_weights import mean_value_laplacian
from .sparse_factor import factorize

#: Rings around the folds re-solved at most (each a larger region than the last).
MAX_REPAIR_RINGS = 8


@dataclass(frozen=True)
class MapFoldRepair:
    """Result of :func:`map_fold_repair`.

    Attributes
    ----------
    target_uv : (n, 2) float64
        The repaired images (the input's where nothing folded or the repair failed).
    folded : (k,) int64
        Triangles folded by the input map.
    moved : (p,) int64
        Vertices whose image was re-solved (empty when nothing folded).
    rings : int
        Rings around the folds re-solved (0 when nothing folded).
    max_displacement : float
        Largest distance an image moved.
    repaired : bool
        True when the returned map folds no triangle.
    """

    target_uv: FloatArray
    folded: IntArray
    moved: IntArray
    rings: int
    max_displacement: float
    repaired: bool


def _grow(F: IntArray, mask: BoolArray) -> BoolArray:
    """The mask grown by one ring (vertices sharing a triangle with a masked vertex)."""
    out = mask.copy()
    out[F[mask[F].any(axis=1)].ravel()] = True
    return out


def map_fold_repair(
    source_uv: FloatArray,
    target_uv: FloatArray,
    F: IntArray,
    *,
    fixed: BoolArray | None = None,
    max_rings: int = MAX_REPAIR_RINGS,
) -> MapFoldRepair:
    """Unfold a planar map locally (see the module docstring).

    Parameters
    ----------
    source_uv : (n, 2) float64
        The source triangulation's vertices (counter-clockwise triangles).
    target_uv : (n, 2) float64
        Their images under the map.
    F : (m, 3) int64
        Triangles.
    fixed : (n,) bool, optional
        Vertices whose image must not move (default none).
    max_rings : int
        Largest region tried, in rings around the folded triangles (≥ 1).

    Returns
    -------
    MapFoldRepair

    Raises
    ------
    ValueError
        On inconsistent shapes or ``max_rings < 1``.

    Examples
    --------
    >>> import numpy as np
    >>> uv = np.array([[0, 0], [1, 0], [0, 1], [-1, 0], [0, -1], [0.1, 0.1]], float)
    >>> F = np.array([[5, 1, 2], [5, 2, 3], [5, 3, 4], [5, 4, 1]])
    >>> bad = uv.copy(); bad[5] = [0.9, 0.9]     # pushed out of its one-ring
    >>> r = map_fold_repair(uv, bad, F, fixed=np.arange(6) < 5)
    >>> r.repaired, r.folded.size > 0, r.moved.tolist()
    (True, True, [5])
    """
    X = np.asarray(source_uv, dtype=np.float64)
    Y = np.asarray(target_uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    n = X.shape[0]
    if X.shape != (n, 2) or Y.shape != (n, 2):
        raise ValueError(f"source_uv and target_uv must both be (n, 2), got {X.shape}, {Y.shape}")
    if F.ndim != 2 or F.shape[1] != 3:
        raise ValueError(f"F must be (m, 3), got {F.shape}")
    if max_rings < 1:
        raise ValueError(f"max_rings must be at least 1, got {max_rings}")
    fixed = np.zeros(n, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool)
    if fixed.shape != (n,):
        raise ValueError(f"fixed must be ({n},), got {fixed.shape}")
    folded = fold_report(X, Y, F).folded_triangles
    if folded.size == 0:
        return MapFoldRepair(Y.copy(), folded, np.zeros(0, np.int64), 0, 0.0, True)
    W = sp.csr_array(mean_value_laplacian(X, F))
    region = np.zeros(n, dtype=bool)
    region[F[folded].ravel()] = True
    for rings in range(1, max_rings + 1):
        region = _grow(F, region) if rings > 1 else region
        free = np.flatnonzero(region & ~fixed)
        if free.size == 0:
            continue
        keep = np.flatnonzero(~region | fixed)
        Wff = sp.csc_array(W[free][:, free])
        rhs = -(W[free][:, keep] @ Y[keep])
        Z = Y.copy()
        Z[free] = factorize(Wff, symmetric=False).solve(rhs)
        if fold_report(X, Z, F).folded_triangles.size == 0:
            moved = np.linalg.norm(Z - Y, axis=1)
            return MapFoldRepair(Z, folded, free, rings, float(moved.max()), True)
    return MapFoldRepair(Y.copy(), folded, np.zeros(0, np.int64), max_rings, 0.0, False)
