"""Stage 2a (section 3 of the face paper): every diameter-normalised key aligned rigidly onto
key 0 (landmarks, trimmed to those that move rigidly, then ICP on the rigid part), and the
similarities that carry the aligned frame back to each input."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays


def similarity(R: Any, t: Any, s: Any) -> Any:
    """The :class:`conformorph.geometry.rigid_alignment.SimilarityTransform` x ↦ s R x + t."""
    from conformorph.geometry.rigid_alignment import SimilarityTransform

    return SimilarityTransform(np.asarray(R), np.asarray(t), float(s))


@dataclass(frozen=True)
class RigidAlignment:
    """Rigid motions of the normalised keys onto key 0.

    Attributes
    ----------
    rotations : list of (3, 3) float64
        R_i (identity for key 0).
    translations : list of (3,) float64
        t_i (zero for key 0); key i aligned is ``Vn_i @ R_i.T + t_i``.
    meta : list of dict
        Per key 1 … N: ``mesh, rms_all, rms_rigid, n_rigid_landmarks,
        icp_iterations, icp_rms``.
    """

    rotations: list[NDArray[np.float64]]
    translations: list[NDArray[np.float64]]
    meta: list[dict[str, Any]]

    def aligned(self, i: int, X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Points (p, 3) of key i's normalised frame in the aligned frame."""
        return np.asarray(X @ self.rotations[i].T + self.translations[i])


def align_keys(prepared: Sequence[Arrays], *, icp_iterations: int = 10) -> RigidAlignment:
    """Align every normalised key onto key 0 (landmarks, trimmed, plus ICP).

    Parameters
    ----------
    prepared : sequence of stage-1 dicts
        Their ``lm_points`` (m, 3) and ``Vn`` (n_i, 3).
    icp_iterations : int
        ICP refinement after the trimmed landmark fit
        (:func:`conformorph.geometry.rigid_alignment.rigid_landmark_alignment`).

    Returns
    -------
    RigidAlignment
    """
    from conformorph.geometry.rigid_alignment import RigidAlignmentOptions, rigid_landmark_alignment

    rotations, translations = [np.eye(3)], [np.zeros(3)]
    meta: list[dict[str, Any]] = []
    for i in range(1, len(prepared)):
        G, info = rigid_landmark_alignment(
            prepared[i]["lm_points"],
            prepared[0]["lm_points"],
            source_surface=prepared[i]["Vn"],
            target_surface=prepared[0]["Vn"],
            options=RigidAlignmentOptions(icp_iterations=icp_iterations),
        )
        rotations.append(G.rotation)
        translations.append(G.translation)
        meta.append(
            {
                "mesh": i,
                "rms_all": info.rms_all,
                "rms_rigid": info.rms_rigid,
                "n_rigid_landmarks": int(info.rigid.sum()),
                "icp_iterations": info.icp_iterations,
                "icp_rms": info.icp_rms,
            }
        )
    return RigidAlignment(rotations, translations, meta)


def input_similarities(prepared: Sequence[Arrays], rigid: RigidAlignment) -> Arrays:
    """The similarities S_i = N_i ∘ G_i⁻¹ from the aligned frame back to each input.

    Parameters
    ----------
    prepared : sequence of stage-1 dicts
        Their normalisation ``norm_translation`` (3,), ``norm_scale``.
    rigid : RigidAlignment

    Returns
    -------
    dict
        ``key_R (N+1, 3, 3)``, ``key_t (N+1, 3)``, ``key_s (N+1,)``.
    """
    Rs, ts, ss = [], [], []
    for i, p in enumerate(prepared):
        G = similarity(rigid.rotations[i], rigid.translations[i], 1.0)
        Nrm = similarity(np.eye(3), p["norm_translation"], p["norm_scale"])
        S = Nrm.compose(G.inverse())
        Rs.append(S.rotation)
        ts.append(S.translation)
        ss.append(S.scale)
    return {"key_R": np.stack(Rs), "key_t": np.stack(ts), "key_s": np.array(ss)}
