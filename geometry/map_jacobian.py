"""Jacobian determinants and folds of a piecewise-linear planar map.

A registration map of the disk must be a bijection (section 3 of the face
morphing paper: "the deformation map on the parametric domain is smooth
without folding and tangling"). Given a triangulation of the source disk and
the images of its vertices, the map is affine on every triangle and its
Jacobian determinant there is the ratio of signed areas.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .flipped_triangles import signed_areas_2d


@dataclass(frozen=True)
class FoldReport:
    """Where a piecewise-linear map folds.

    Attributes
    ----------
    min_jacobian_determinant : float
        Smallest per-triangle Jacobian determinant (signed area ratio);
        ≤ 0 means a fold.
    folded_triangles : (k,) int64
        Triangles whose image is flipped, degenerate or non-finite, while the
        source triangle is positively oriented.
    n_source_flipped : int
        Source triangles already flipped or degenerate; they are excluded
        from the determinant (the map is undefined there).
    """

    min_jacobian_determinant: float
    folded_triangles: IntArray
    n_source_flipped: int

    @property
    def n_folded(self) -> int:
        """Number of folded triangles."""
        return int(self.folded_triangles.size)

    @property
    def is_bijective(self) -> bool:
        """True when no triangle folds."""
        return self.n_folded == 0


def map_jacobian_determinants(
    source_uv: FloatArray, target_uv: FloatArray, F: IntArray
) -> FloatArray:
    """Per-triangle Jacobian determinant of the piecewise-linear map source_uv → target_uv.

    Parameters
    ----------
    source_uv : (n, 2) float64
        Vertex positions before the map.
    target_uv : (n, 2) float64
        Vertex positions after the map.
    F : (m, 3) int64
        Triangles.

    Returns
    -------
    det : (m,) float64
        Signed area after / signed area before; NaN where the source triangle
        has zero area.

    Examples
    --------
    >>> import numpy as np
    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> map_jacobian_determinants(uv, 2.0 * uv, np.array([[0, 1, 2]])).tolist()
    [4.0]
    """
    source_uv = np.asarray(source_uv, dtype=np.float64)
    target_uv = np.asarray(target_uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if source_uv.shape != target_uv.shape or source_uv.ndim != 2 or source_uv.shape[1] != 2:
        raise ValueError(
            f"source_uv and target_uv must both be (n, 2), got {source_uv.shape}, {target_uv.shape}"
        )
    if F.ndim != 2 or F.shape[1] != 3:
        raise ValueError(f"F must be (m, 3), got {F.shape}")
    if F.size and (F.min() < 0 or F.max() >= source_uv.shape[0]):
        raise ValueError(f"F indexes vertices outside 0..{source_uv.shape[0] - 1}")
    a0 = signed_areas_2d(source_uv, F)
    a1 = signed_areas_2d(target_uv, F)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(np.where(a0 != 0.0, a1 / np.where(a0 != 0.0, a0, 1.0), np.nan))


def fold_report(source_uv: FloatArray, target_uv: FloatArray, F: IntArray) -> FoldReport:
    """Minimum Jacobian determinant and folded triangles of a piecewise-linear planar map.

    Parameters
    ----------
    source_uv : (n, 2) float64
        Vertex positions before the map (counter-clockwise triangles).
    target_uv : (n, 2) float64
        Vertex positions after the map.
    F : (m, 3) int64
        Triangles.

    Returns
    -------
    FoldReport

    Examples
    --------
    >>> import numpy as np
    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> fold_report(uv, uv * [[-1.0, 1.0]], np.array([[0, 1, 2]])).n_folded
    1
    """
    det = map_jacobian_determinants(source_uv, target_uv, F)
    src_ok = signed_areas_2d(np.asarray(source_uv, dtype=np.float64), F) > 0
    d = det[src_ok]
    # a non-finite image (e.g. an overflowing map) counts as folded, never as fine
    folded = np.nonzero(src_ok & ~(det > 0))[0].astype(np.int64)
    return FoldReport(
        min_jacobian_determinant=float(np.nanmin(np.where(np.isfinite(d), d, -np.inf)))
        if d.size
        else float("nan"),
        folded_triangles=folded,
        n_source_flipped=int((~src_ok).sum()),
    )
