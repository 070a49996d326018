"""Step 4 of :mod:`conformorph.pipelines.conformal`: the surface from (H, λ) and its boundary (Algorithm 1)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from conformorph import geometry
from conformorph.geometry.reconstruct_surface import ReconstructionInfo
from conformorph.pipelines.conformal.disk_mesh import DiskMesh


@dataclass(frozen=True)
class ReconstructionStepOptions:
    """Options of :func:`reconstruction_step`.

    Attributes
    ----------
    fold_correction : bool
        Where the disk map folds, solve the surface's own Laplace equations
        (:func:`conformorph.geometry.fold_correction`); applied only with the
        mean-curvature vector, and meant for the harmonic map (no angle
        refinement). Default False.
    """

    fold_correction: bool = False


@dataclass(frozen=True)
class ReconstructionResult:
    """What :func:`reconstruction_step` gives.

    Attributes
    ----------
    X : (n2, 3) float64
        The reconstruction on the repaired mesh's rows.
    X_input : (n, 3) float64
        On the input's rows; removed ears keep their input positions.
    info : ReconstructionInfo
    errors : dict of str to float
        Relative errors ``L1``, ``L2``, ``Linf``
        (:func:`conformorph.geometry.reconstruction_error`).
    """

    X: np.ndarray
    X_input: np.ndarray
    info: ReconstructionInfo
    errors: dict[str, float]


def reconstruction_step(
    mesh: DiskMesh,
    uv: np.ndarray,
    H: np.ndarray,
    lam: np.ndarray,
    options: ReconstructionStepOptions,
) -> ReconstructionResult:
    """Algorithm 1: solve ``Δ_uv X = 2 H λ n`` with the boundary fixed
    (:func:`conformorph.geometry.reconstruct_surface`), and measure it against the mesh.

    Parameters
    ----------
    mesh : DiskMesh
    uv : (n2, 2) float64
        The disk map of the repaired mesh.
    H : (n2,) or (n2, 3) float64
    lam : (n2,) float64
        From :func:`conformorph.pipelines.conformal.curvature.curvature_step`.
    options : ReconstructionStepOptions

    Returns
    -------
    ReconstructionResult
    """
    V, F = mesh.V, mesh.F
    b = np.asarray(geometry.boundary_loop(F), dtype=np.int64)
    # the fold correction needs the vector H
    correct = options.fold_correction and H.ndim == 2
    X, info = geometry.reconstruct_surface(
        uv, F, H, lam, V[b], b=b, options=geometry.ReconstructionOptions(correct_folds=correct)
    )
    errors = {k: float(v) for k, v in geometry.reconstruction_error(V, X, F).items()}
    return ReconstructionResult(X, mesh.input_rows(X, mesh.V_filled), info, errors)
