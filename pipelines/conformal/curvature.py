"""Step 3 of :mod:`conformorph.pipelines.conformal`: the (H, λ) representation of the surface."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from conformorph import geometry
from conformorph.pipelines.conformal.disk_mesh import DiskMesh


@dataclass(frozen=True)
class CurvatureOptions:
    """Options of :func:`curvature_step`.

    Attributes
    ----------
    curvature : {"vector", "scalar"}
        The mean-curvature vector (:func:`geometry.mean_curvature_vector`,
        reconstructed by one solve; default) or the paper's scalar H
        (:func:`conformorph.geometry.mean_curvature`, reconstructed by Algorithm 1).
    """

    curvature: Literal["vector", "scalar"] = "vector"


@dataclass(frozen=True)
class CurvatureResult:
    """What :func:`curvature_step` gives.

    Attributes
    ----------
    H : (n2,) or (n2, 3) float64
        Mean curvature on the repaired mesh's rows.
    lam : (n2,) float64
        Conformal factor on the repaired mesh's rows.
    H_input, lam_input : (n,) or (n, 3), (n,) float64
        The same on the input's rows, NaN for a removed ear (hole centres
        left out).
    """

    H: np.ndarray
    lam: np.ndarray
    H_input: np.ndarray
    lam_input: np.ndarray


def curvature_step(mesh: DiskMesh, uv: np.ndarray, options: CurvatureOptions) -> CurvatureResult:
    """Mean curvature H and conformal factor λ (eq. 1's data) of the repaired mesh.

    Parameters
    ----------
    mesh : DiskMesh
    uv : (n2, 2) float64
        Its disk map (rows of ``mesh.V``).
    options : CurvatureOptions

    Returns
    -------
    CurvatureResult
    """
    V, F = mesh.V, mesh.F
    if options.curvature == "vector":
        H = geometry.mean_curvature_vector(V, F)
    else:
        H = geometry.mean_curvature(V, F)
    lam = geometry.conformal_factor(V, F, uv)
    H, lam = np.asarray(H, dtype=np.float64), np.asarray(lam, dtype=np.float64)
    n_filled = mesh.V_filled.shape[0]
    H_in, lam_in = (mesh.input_rows(a, np.full((n_filled, *a.shape[1:]), np.nan)) for a in (H, lam))
    return CurvatureResult(H, lam, H_in, lam_in)
