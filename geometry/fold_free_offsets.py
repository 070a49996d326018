"""The part of a per-vertex offset of a planar map that folds no triangle.

Used to put dense correspondences (e.g. the non-rigid ICP's closest points) on
top of a smooth, bijective registration without losing bijectivity: the offset
is kept wherever it keeps every triangle's orientation and dropped, locally,
wherever it would fold one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray
from .map_jacobian import map_jacobian_determinants


@dataclass(frozen=True)
class FoldFreeOffsets:
    """Result of :func:`fold_free_offsets`.

    Attributes
    ----------
    offsets : (n, 2) float64
        The kept offsets: the input's, with zero rows where they were dropped.
    dropped : (n,) bool
        Vertices whose (non-zero) offset was dropped.
    rounds : int
        Rounds of dropping until no triangle folded (0: nothing folded).
    """

    offsets: FloatArray
    dropped: BoolArray
    rounds: int


def fold_free_offsets(
    source_uv: FloatArray,
    base: FloatArray,
    offsets: FloatArray,
    F: IntArray,
    *,
    min_jacobian: float = 0.0,
) -> FoldFreeOffsets:
    """Drop the offsets that fold a triangle of ``base + offsets``, with a one-ring margin.

    A triangle folds when the piecewise-linear map from ``source_uv`` to
    ``base + kept`` has a Jacobian determinant that is not positive there
    (:func:`conformorph.geometry.map_jacobian.map_jacobian_determinants`; a triangle of zero
    source area counts as folded). Each round finds those triangles and sets the
    offset to zero on their vertices and on every vertex of a triangle touching
    them. The rounds end when nothing folds; since ``base`` itself must fold
    nothing, they end at the latest when every offset is dropped. Greedy and local (no optimisation): where two
    maps disagree on a fold, the base map wins near it and the offset elsewhere.

    Parameters
    ----------
    source_uv : (n, 2) float64
        The vertices in the map's domain (either orientation per triangle).
    base : (n, 2) float64
        Their image under a map that folds no triangle.
    offsets : (n, 2) float64
        Wanted changes of the images.
    F : (m, 3) int64
        Triangles.
    min_jacobian : float, optional
        Also drop the offsets that bring a triangle's Jacobian determinant below this
        floor (≥ 0) and below the base map's own there: a nearly vanishing
        Jacobian is a fold in waiting (a later nonlinear map of the vertices, e.g. a
        Möbius transformation, flips a thin enough triangle). Default 0: folds only.

    Returns
    -------
    FoldFreeOffsets

    Raises
    ------
    ValueError
        On mismatched shapes, or if ``base`` itself folds a triangle.

    Examples
    --------
    >>> import numpy as np
    >>> base = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> F = np.array([[0, 1, 2], [1, 3, 2]])
    >>> d = np.array([[0.1, 0.0], [0.0, 0.0], [0.0, 0.0], [-2.0, -2.0]])
    >>> r = fold_free_offsets(base, base, d, F)
    >>> r.dropped.tolist(), r.rounds
    ([True, False, False, True], 1)
    """
    source = np.asarray(source_uv, dtype=np.float64)
    base = np.asarray(base, dtype=np.float64)
    kept = np.array(offsets, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if base.ndim != 2 or base.shape[1] != 2 or not kept.shape == base.shape == source.shape:
        raise ValueError(
            f"source_uv, base and offsets must all be (n, 2), got {source.shape}, "
            f"{base.shape}, {kept.shape}"
        )

    if not (np.isfinite(min_jacobian) and min_jacobian >= 0):
        raise ValueError(f"min_jacobian must be finite and ≥ 0, got {min_jacobian}")
    det_base = map_jacobian_determinants(source, base, F)
    if (~(det_base > 0)).any():
        raise ValueError("the base map folds a triangle: there is no fold-free part to keep")

    def folds(image: FloatArray) -> BoolArray:
        det = map_jacobian_determinants(source, image, F)
        return np.asarray(~(det > 0) | ((det < min_jacobian) & (det < det_base)))

    moved = np.any(kept != 0.0, axis=1)
    rounds = 0
    while True:
        folded = folds(base + kept)
        if not folded.any():
            break
        rounds += 1
        near = np.zeros(base.shape[0], dtype=bool)
        near[F[folded]] = True
        ring = near[F].any(axis=1)
        near[F[ring]] = True
        kept[near] = 0.0
    dropped = moved & ~np.any(kept != 0.0, axis=1)
    return FoldFreeOffsets(kept, dropped, rounds)
