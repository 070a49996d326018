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
from .flipped_triangles import signed_areas_2d


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
    base: FloatArray, offsets: FloatArray, F: IntArray, orientation: FloatArray
) -> FoldFreeOffsets:
    """Drop the offsets that fold a triangle of ``base + offsets``, with a one-ring margin.

    Each round finds the triangles of ``base + kept`` whose signed area has not
    the sign of ``orientation`` (or is 0), and sets the offset to zero on their
    vertices and on every vertex of a triangle touching them. The rounds end when
    nothing folds; since ``base`` itself must fold nothing, they end at the latest
    when every offset is dropped. Greedy and local (no optimisation): where two
    maps disagree on a fold, the base map wins near it and the offset elsewhere.

    Parameters
    ----------
    base : (n, 2) float64
        A map of the vertices that folds no triangle.
    offsets : (n, 2) float64
        Wanted changes of the vertices' positions.
    F : (m, 3) int64
        Triangles.
    orientation : (m,) float64
        Signed areas of the triangles in their reference layout (only the signs
        are used), e.g. :func:`geometry.flipped_triangles.signed_areas_2d` of
        the map's domain.

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
    >>> r = fold_free_offsets(base, d, F, np.ones(2))
    >>> r.dropped.tolist(), r.rounds
    ([True, False, False, True], 1)
    """
    base = np.asarray(base, dtype=np.float64)
    kept = np.array(offsets, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    sign = np.sign(np.asarray(orientation, dtype=np.float64))
    if base.ndim != 2 or base.shape[1] != 2 or kept.shape != base.shape:
        raise ValueError(f"base and offsets must both be (n, 2), got {base.shape}, {kept.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or sign.shape != (F.shape[0],):
        raise ValueError(
            f"need (m, 3) triangles and (m,) orientations, got {F.shape}, {sign.shape}"
        )
    if np.any(signed_areas_2d(base, F) * sign <= 0):
        raise ValueError("the base map folds a triangle: there is no fold-free part to keep")
    moved = np.any(kept != 0.0, axis=1)
    rounds = 0
    while True:
        folded = signed_areas_2d(base + kept, F) * sign <= 0
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
