"""The exact-landmark dense refinement's vertex pull (issue 27: features slide)."""

import numpy as np

import conformorph.pipelines.face_morph.dense_refinement as dense
from conformorph.pipelines.face_morph import RegistrationOptions, prepare_mesh, register_meshes

from .face_fixtures import face_mesh


def _per_vertex_errors(prep, **options):
    """Distance of every consistent node's key-1 point to where the shared connectivity
    puts it (the identity registration), in key 1's diameters."""
    reg = register_meshes(prep, RegistrationOptions(baselines=False, **options))
    truth = register_meshes(prep, RegistrationOptions(baselines=False, method="identity"))
    X, T = reg["key_X__main"][1], truth["key_X__main"][1]
    return np.linalg.norm(X - T, axis=1), reg["meta"]


def test_vertex_pull_holds_the_nodes_where_the_target_vertices_are(monkeypatch):
    monkeypatch.setattr(dense, "EXACT_VERTEX_PULL", 0.5)
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    pulled, meta = _per_vertex_errors(prep)
    nicp = meta["pairs"][0]["nicp"]
    assert nicp["vertex_pull"] == 0.5
    assert not nicp["vertex_pull_fallback"]
    assert meta["composite_folded_triangles"]["main"] == [0]
    monkeypatch.setattr(dense, "EXACT_VERTEX_PULL", 0.0)  # the default
    plain, meta0 = _per_vertex_errors(prep)
    assert meta0["pairs"][0]["nicp"]["vertex_pull"] == 0.0
    assert meta0["pairs"][0]["nicp"]["attempts"] == [
        [1000, meta0["pairs"][0]["nicp"]["dense_nodes"]]
    ]
    # measured: mean 4.1e-3 → 2.5e-3, median 2.6e-3 → 6.0e-4 diameters
    assert pulled.mean() < 0.75 * plain.mean()
    assert np.median(pulled) < 0.4 * np.median(plain)


def test_when_the_pulled_fits_fold_the_attempt_whose_fit_took_more_samples_is_kept(
    monkeypatch,
):
    """One landmark misplaced by 3 % of the diameter: the exact fits through the pulled
    ICP's samples fold (the landmark DMT is kept), so the ICP runs again without the pull;
    kept is the attempt whose fit took more samples, then put more nodes on their own
    correspondences."""
    from .test_face_landmark_fit import _moved_landmark

    monkeypatch.setattr(dense, "EXACT_VERTEX_PULL", 0.5)
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    diam = float(np.linalg.norm(np.ptp(V1, axis=0)))
    bad, _ = _moved_landmark(V1, lm1, 3, 0.03 * diam)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, bad, mesh_index=1)]
    reg = register_meshes(prep, RegistrationOptions(baselines=False))
    nicp = reg["meta"]["pairs"][0]["nicp"]
    attempts = [tuple(a) for a in nicp["attempts"]]
    assert len(attempts) == 2 and len(nicp["tried"]) > 1
    assert (nicp["correspondences"], nicp["dense_nodes"]) == max(attempts)
    assert nicp["vertex_pull_fallback"] == (attempts[1] > attempts[0])
    assert nicp["vertex_pull"] == (0.0 if nicp["vertex_pull_fallback"] else 0.5)
    assert reg["meta"]["composite_folded_triangles"]["main"] == [0]
