"""Relative reconstruction errors in L1, L2 and L∞ (section 2.3 of the face paper)."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .vertex_areas import vertex_areas


def reconstruction_error(V_true: FloatArray, V_rec: FloatArray, F: IntArray) -> dict[str, float]:
    """Area-weighted distance between two embeddings of the same mesh.

    Parameters
    ----------
    V_true : (n, 3) float64
        The surface M.
    V_rec : (n, 3) float64
        The reconstruction M̂, same connectivity and vertex order.
    F : (m, 3) int64

    Returns
    -------
    errors : dict
        ``"L1"``, ``"L2"``, ``"Linf"``: the paper's norms — the integrals of
        ``|M − M̂|`` and ``|M − M̂|²`` against the area element of M
        (``|∂φ⁻¹/∂u1 ∧ ∂φ⁻¹/∂u2| du``), normalised by the total area, the
        latter square-rooted, and the maximum — each divided by the bounding
        box diagonal of M. Integrals use barycentric vertex areas of M
        (lumped quadrature).
    """
    V_true = np.asarray(V_true, dtype=np.float64)
    V_rec = np.asarray(V_rec, dtype=np.float64)
    if V_true.shape != V_rec.shape:
        raise ValueError(f"shapes differ: {V_true.shape} vs {V_rec.shape}")
    A = vertex_areas(V_true, F)
    d = np.linalg.norm(V_true - V_rec, axis=1)
    diag = float(np.linalg.norm(V_true.max(axis=0) - V_true.min(axis=0)))
    return {
        "L1": float((A * d).sum() / A.sum() / diag),
        "L2": float(np.sqrt((A * d**2).sum() / A.sum()) / diag),
        "Linf": float(d.max() / diag),
    }
