"""The registration's landmark fit: ``exact`` (the paper's DMT) and ``tolerant``
(confidence-weighted, smoothed, corrected by the non-rigid ICP)."""

import json

import numpy as np
import pytest

from conformorph.pipelines.face_morph import RegistrationOptions, prepare_mesh, register_meshes
from conformorph.pipelines.landmark_document import LandmarkFormatError, landmark_confidence

from .face_fixtures import face_mesh
from .face_morph_inputs import face_inputs, morph


def _moved_landmark(V, lm, k, dist):
    """Landmark k moved to the vertex nearest ``dist`` away from it (a misplaced click)."""
    d = np.linalg.norm(V - V[lm[k]], axis=1)
    j = int(np.argmin(np.abs(d - dist)))
    out = list(lm)
    out[k] = j
    return out, float(d[j])


def test_tolerant_fit_corrects_a_misplaced_landmark():
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    diam = float(np.linalg.norm(np.ptp(V1, axis=0)))
    k = 3
    bad, moved = _moved_landmark(V1, lm1, k, 0.03 * diam)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, bad, mesh_index=1)]
    exact = register_meshes(prep, RegistrationOptions(baselines=False))
    tol = register_meshes(prep, RegistrationOptions(baselines=False, landmark_fit="tolerant"))
    assert exact["meta"]["landmark_fit"] == "exact" and tol["meta"]["landmark_fit"] == "tolerant"
    assert exact["meta"]["pairs"][0]["nicp"]["corrected_landmarks"] is None
    n = tol["meta"]["pairs"][0]["nicp"]
    corrected = np.asarray(n["corrected_landmarks"])
    assert corrected.shape == (len(lm1), 3) and n["corrected_landmark_shift"] > 0
    assert tol["meta"]["composite_folded_triangles"]["main"] == [0]
    # the misplaced landmark is moved back towards where it belongs (same vertex ids);
    # only a little with the default pull (β = 10 through the stiff stages, needed on ICT
    # faces against tangential sliding): 0.088 → 0.083 here
    err = float(np.linalg.norm(corrected[k] - V1[lm1[k]]))
    assert err < moved
    # and the others stay near theirs
    others = np.delete(np.arange(len(lm1)), k)
    np.testing.assert_allclose(corrected[others], V1[np.asarray(lm1)[others]], atol=0.01 * diam)


def test_tolerant_fit_with_exact_landmarks_keeps_them():
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    diam = float(np.linalg.norm(np.ptp(V1, axis=0)))
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    tol = register_meshes(prep, RegistrationOptions(baselines=False, landmark_fit="tolerant"))
    corrected = np.asarray(tol["meta"]["pairs"][0]["nicp"]["corrected_landmarks"])
    assert np.linalg.norm(corrected - V1[lm1], axis=1).max() < 0.01 * diam
    # low confidence on one landmark lowers its weight: the fit still runs, unfolded
    conf = np.ones(len(lm1))
    conf[0] = 0.0
    prep_c = [prep[0], prepare_mesh(V1, F1, lm1, mesh_index=1, landmark_confidence=conf)]
    assert prep_c[1]["lm_confidence"][0] == 0.0
    low = register_meshes(prep_c, RegistrationOptions(baselines=False, landmark_fit="tolerant"))
    assert low["meta"]["composite_folded_triangles"]["main"] == [0]


def test_options_and_confidence_are_checked():
    V0, F0, lm0 = face_mesh(0.0)
    p0 = prepare_mesh(V0, F0, lm0)
    np.testing.assert_array_equal(p0["lm_confidence"], np.ones(len(lm0)))
    with pytest.raises(ValueError, match="landmark_fit"):
        register_meshes([p0, p0], RegistrationOptions(landmark_fit="loose"))
    with pytest.raises(ValueError, match="landmark_noise"):
        register_meshes([p0, p0], RegistrationOptions(landmark_noise=0.0))
    with pytest.raises(ValueError, match="confidence"):
        prepare_mesh(V0, F0, lm0, landmark_confidence=np.full(len(lm0), 1.5))
    with pytest.raises(ValueError, match="confidence"):
        prepare_mesh(V0, F0, lm0, landmark_confidence=np.ones(2))
    assert landmark_confidence({"landmarks": [[1, 2, 3]]}, 1) == [None]
    assert landmark_confidence({"confidence": [[0.5, 1]]}, 1) == [[0.5, 1.0]]
    for bad in ([[0.5, 2.0]], [[0.5]], [[True]], "x"):
        with pytest.raises(LandmarkFormatError, match="confidence"):
            landmark_confidence({"confidence": bad}, 1 if bad != [[0.5]] else 2)


def test_run_writes_the_corrected_landmarks(tmp_path):
    paths, L = face_inputs(tmp_path)
    doc = json.loads(L.read_text())
    doc["confidence"] = [[1.0] * len(doc["landmarks"][0])] * 2
    L.write_text(json.dumps(doc))
    out = tmp_path / "out"
    m = morph(paths, L, out, frames=3, write_glb=False, landmark_fit="tolerant")
    assert m["registration"]["landmark_fit"] == "tolerant"
    written = json.loads((out / "landmarks_corrected.json").read_text())
    assert len(written["landmarks"]) == 2 and len(written["landmarks"][1]) == len(
        doc["landmarks"][1]
    )
    m2 = morph(paths, L, tmp_path / "out2", frames=3, write_glb=False)
    assert m2["registration"]["landmark_fit"] == "exact"
    assert not (tmp_path / "out2" / "landmarks_corrected.json").exists()


def test_tolerant_dense_fit_retries_its_samples_away_from_the_rim(monkeypatch):
    """One landmark misplaced by 3 % of the diameter: every dense fit through the ICP's
    samples within |z| < 0.95 folds (the exact fit halves them down to 125 and keeps its
    landmark DMT); the tolerant fit retries the 1000 samples within 0.9, which hold."""
    import conformorph.pipelines.face_morph.dense_refinement as dense

    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    diam = float(np.linalg.norm(np.ptp(V1, axis=0)))
    bad, _ = _moved_landmark(V1, lm1, 3, 0.03 * diam)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, bad, mesh_index=1)]

    def nicp(fit):
        reg = register_meshes(prep, RegistrationOptions(baselines=False, landmark_fit=fit))
        assert reg["meta"]["composite_folded_triangles"]["main"] == [0]
        return reg["meta"]["pairs"][0]

    exact, tol = nicp("exact"), nicp("tolerant")
    assert exact["nicp"]["tried"] == [1000, 500, 250, 125]
    assert exact["nicp"]["correspondences"] == 0
    assert tol["nicp"]["tried"] == [1000, 1000]  # radius 0.95, then 0.9
    assert tol["nicp"]["correspondences"] == 1000
    # the exact fit interpolates the misplaced landmark, the tolerant one does not
    # (its dense fit leaves the landmarks out)
    assert exact["E_D"]["dmt"] < 1e-8 < 1e-3 < tol["E_D"]["dmt"]
    # with the first radius only, the tolerant fit meets the same folds
    monkeypatch.setattr(dense, "TOLERANT_SAMPLE_RADII", (0.95,))
    assert nicp("tolerant")["nicp"]["correspondences"] == 0


def test_resolve_landmark_fit_picks_by_where_the_landmarks_come_from():
    from conformorph.pipelines.face_morph import LANDMARK_FIT_CHOICES, resolve_landmark_fit

    assert resolve_landmark_fit("auto", detected=True) == "tolerant"
    assert resolve_landmark_fit("auto", detected=False) == "exact"
    for fit in ("exact", "tolerant"):  # an explicit choice always wins
        assert resolve_landmark_fit(fit, detected=True) == fit
        assert resolve_landmark_fit(fit, detected=False) == fit
    assert set(LANDMARK_FIT_CHOICES) == {"auto", "exact", "tolerant"}
    with pytest.raises(ValueError, match="landmark_fit must be one of auto, exact, tolerant"):
        resolve_landmark_fit("loose", detected=False)
