"""Metrics of one strain-morph attempt: frame quality, convergence, distance to the target."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.morph_metrics_2d import morph_metrics_2d
from conformorph.geometry.strain_morph import StrainMorphInfo

#: The morph has reached the target when its last frame converged and lies
#: within this fraction of the target's bounding-box diagonal of the target mesh
#: (a converged last frame: ~1e-12, see ``STRAIN_NEWTON_STEP_RTOL``).
TARGET_MATCH_RTOL = 1e-6


def strain_metrics(
    S: NDArray[np.float64],
    T: NDArray[np.float64],
    F: NDArray[np.int64],
    seq: NDArray[np.float64],
    info: StrainMorphInfo,
    scheme: str,
) -> dict[str, Any]:
    """Metrics of one strain-morph run, with per-frame convergence and the distance to the target.

    Parameters
    ----------
    S, T : (n, 2) float64
        Source and target meshes' vertices.
    F : (m, 3) int64
    seq : (k, n, 2) float64
        The frames.
    info : StrainMorphInfo
    scheme : str

    Returns
    -------
    dict
        :func:`conformorph.geometry.morph_metrics_2d.morph_metrics_2d` of the frames, with the
        solver's records, ``target_error`` (largest distance of the last frame
        from the target over the target's bounding-box diagonal) and
        ``reached_target`` (last frame converged and within ``TARGET_MATCH_RTOL``).
    """
    diag = float(np.linalg.norm(np.ptp(T, axis=0)))
    err = float(np.abs(seq[-1] - T).max() / diag)
    m = morph_metrics_2d(S, F, seq).as_dict()
    m.update(
        seconds=info.seconds,
        scheme=scheme,
        newton_iterations=info.iterations.tolist(),
        continuation=info.continuation.tolist(),
        substeps=info.substeps.tolist(),
        converged=info.converged,
        stop_reasons=list(info.stop_reasons),
        frames=[
            {"t": float(t), "converged": r == "converged", "stop_reason": r, "scheme": scheme}
            for t, r in zip(info.times, info.stop_reasons, strict=True)
        ],
        target_error=err,
        reached_target=info.stop_reasons[-1] == "converged" and err <= TARGET_MATCH_RTOL,
        rotation=info.rotation,
        translation=info.translation.tolist(),
    )
    return m
