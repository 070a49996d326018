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
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    pulled, meta = _per_vertex_errors(prep)
    nicp = meta["pairs"][0]["nicp"]
    assert nicp["vertex_pull"] == dense.EXACT_VERTEX_PULL > 0
    assert not nicp["vertex_pull_fallback"]
    assert meta["composite_folded_triangles"]["main"] == [0]
    monkeypatch.setattr(dense, "EXACT_VERTEX_PULL", 0.0)
    plain, meta0 = _per_vertex_errors(prep)
    assert meta0["pairs"][0]["nicp"]["vertex_pull"] == 0.0
    # measured: mean 4.1e-3 → 2.5e-3, median 2.6e-3 → 6.0e-4 diameters
    assert pulled.mean() < 0.75 * plain.mean()
    assert np.median(pulled) < 0.4 * np.median(plain)


def test_when_every_pulled_fit_folds_the_attempt_with_more_dense_nodes_is_kept():
    """One landmark misplaced by 3 % of the diameter: every exact fit through the pulled
    ICP's samples folds (the landmark DMT is kept), so the ICP runs again without the pull;
    whichever attempt puts more nodes on their own correspondences is kept."""
    from .test_face_landmark_fit import _moved_landmark

    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    diam = float(np.linalg.norm(np.ptp(V1, axis=0)))
    bad, _ = _moved_landmark(V1, lm1, 3, 0.03 * diam)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, bad, mesh_index=1)]
    reg = register_meshes(prep, RegistrationOptions(baselines=False))
    nicp = reg["meta"]["pairs"][0]["nicp"]
    attempts = nicp["attempt_dense_nodes"]
    assert len(attempts) == 2 and nicp["dense_nodes"] == max(attempts)
    assert nicp["vertex_pull_fallback"] == (attempts[1] > attempts[0])
    assert nicp["vertex_pull"] == (0.0 if nicp["vertex_pull_fallback"] else dense.EXACT_VERTEX_PULL)
    assert reg["meta"]["composite_folded_triangles"]["main"] == [0]
