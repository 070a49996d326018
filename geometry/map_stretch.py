"""How far a piecewise-linear map between two compatible planar meshes stretches its triangles."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .green_lagrange_strain import deformation_gradient, shape_function_gradients


@dataclass(frozen=True)
class MapStretch:
    """Extremes of the principal stretches of a source → target map (m triangles).

    Attributes
    ----------
    max_stretch : float
        Largest singular value σ₁ of the deformation gradient over the triangles
        (the most a line element is lengthened).
    min_stretch : float
        Smallest singular value σ₂ over the triangles (the most a line element is
        shortened); ≤ 0 never occurs for a positively oriented target, 0 for a
        degenerate target triangle.
    max_anisotropy : float
        Largest ``σ₁ / σ₂`` of one triangle (1 for a similarity; inf for a
        degenerate target triangle).
    worst_triangle : int
        The triangle with the largest anisotropy.
    """

    max_stretch: float
    min_stretch: float
    max_anisotropy: float
    worst_triangle: int

    def as_dict(self) -> dict[str, float | int]:
        """JSON-ready dictionary."""
        return asdict(self)


def principal_stretches(source_V: FloatArray, target_V: FloatArray, F: IntArray) -> FloatArray:
    """Singular values ``σ₁ ≥ σ₂ ≥ 0`` of each triangle's deformation gradient J.

    Parameters
    ----------
    source_V : (n, 2) float64
    target_V : (n, 2) float64
        Vertex i of the source maps to vertex i of the target.
    F : (m, 3) int64
        Triangles, non-degenerate in ``source_V``.

    Returns
    -------
    (m, 2) float64
        The square roots of the eigenvalues of the right Cauchy–Green tensor
        ``JᵀJ = I + 2E`` (E the Green–Lagrange strain of eq. 1), computed as
        ``σ₁ = (p + q) / 2``, ``σ₂ = |det J| / σ₁`` with ``p = |(J₀₀ + J₁₁, J₁₀ − J₀₁)|``,
        ``q = |(J₀₀ − J₁₁, J₁₀ + J₀₁)|``.

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> principal_stretches(V, V * [2.0, 1.0], np.array([[0, 1, 2]])).tolist()
    [[2.0, 1.0]]
    """
    source_V = np.asarray(source_V, dtype=np.float64)
    target_V = np.asarray(target_V, dtype=np.float64)
    if target_V.shape != source_V.shape:
        raise ValueError(f"target_V has shape {target_V.shape}, expected {source_V.shape}")
    dN, _ = shape_function_gradients(source_V, F)
    J = deformation_gradient(dN, target_V, np.asarray(F, dtype=np.int64))
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    # J = conformal part + anticonformal part, |σ₁,₂| = (p ± q) / 2 (no cancellation
    # near a similarity, where ‖J‖⁴_F − 4 det² J loses half the digits)
    p = np.hypot(a + d, c - b)
    q = np.hypot(a - d, c + b)
    s1 = 0.5 * (p + q)
    # σ₂ = |det| / σ₁ avoids the cancellation of (p − q) / 2 for thin triangles
    det = a * d - b * c
    s2 = np.divide(np.abs(det), s1, out=np.zeros_like(s1), where=s1 > 0)
    return np.asarray(np.c_[s1, s2], dtype=np.float64)


def map_stretch(source_V: FloatArray, target_V: FloatArray, F: IntArray) -> MapStretch:
    """Largest stretch, shortening and anisotropy of the map between two compatible meshes.

    A cheap check of a compatible triangulation before a morph: anchors that pair
    different features of the two shapes (a stroke end with the middle of a side)
    force the map to squeeze one part of a shape into a sliver of the other, which
    shows as anisotropies of hundreds; the strain morph then has to realise those
    strains and may not reach the target.

    Parameters
    ----------
    source_V : (n, 2) float64
    target_V : (n, 2) float64
    F : (m, 3) int64
        Triangles, non-degenerate in ``source_V``.

    Returns
    -------
    MapStretch

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> s = map_stretch(V, V @ np.array([[1.0, 0], [1, 1]]), np.array([[0, 1, 2]]))  # shear 1
    >>> round(s.max_anisotropy, 6)  # golden ratio squared
    2.618034
    """
    s = principal_stretches(source_V, target_V, F)
    with np.errstate(divide="ignore"):
        aniso = np.where(s[:, 1] > 0, s[:, 0] / np.where(s[:, 1] > 0, s[:, 1], 1.0), np.inf)
    k = int(np.argmax(aniso))
    return MapStretch(
        max_stretch=float(s[:, 0].max()),
        min_stretch=float(s[:, 1].min()),
        max_anisotropy=float(aniso[k]),
        worst_triangle=k,
    )
