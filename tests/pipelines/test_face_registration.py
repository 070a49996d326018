import numpy as np
import pytest

from conformorph.pipelines.face_morph import (
    RegistrationOptions,
    load_stage,
    prepare_mesh,
    register_meshes,
    save_stage,
)

from .face_fixtures import face_mesh
from .face_morph_inputs import (
    folded_face,
)


def test_stages_roundtrip_through_npz(tmp_path):
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    p0 = prepare_mesh(V0, F0, lm0)
    save_stage(tmp_path / "p0.npz", p0)
    q0 = load_stage(tmp_path / "p0.npz")
    assert set(q0) == set(p0)
    for k, v in p0.items():
        if k != "meta":
            np.testing.assert_array_equal(q0[k], v)
    assert q0["meta"]["n_vertices"] == V0.shape[0]
    reg = register_meshes([q0, prepare_mesh(V1, F1, lm1, mesh_index=1)])
    save_stage(tmp_path / "reg.npz", reg)
    r = load_stage(tmp_path / "reg.npz")
    assert r["key_uv__main"].shape == (2, V0.shape[0], 2) and r["meta"]["method"] == "dmt"


def test_refine_presets():
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    paper = register_meshes(prep, RegistrationOptions(refine="none", baselines=False))
    assert paper["meta"]["pairs"][0]["static_correspondences"] == []
    guided = register_meshes(prep, RegistrationOptions(refine="guided", baselines=False))
    g = guided["meta"]["pairs"][0]
    assert guided["meta"]["refine"]["guided"] is True
    assert len(g["static_correspondences"]) == 1
    assert g["folded_triangles"]["dmt"] == 0
    # landmarks stay matched exactly whatever the extra correspondences did
    assert g["E_D"]["dmt"] < 1e-8
    nicp = register_meshes(prep, RegistrationOptions(baselines=False, refine="nicp"))
    assert nicp["meta"]["refine"]["preset"] == nicp["meta"]["refine"]["used"] == "nicp"
    # the default, auto: nicp on this small consistent mesh, guided above the node budget
    auto = register_meshes(prep, RegistrationOptions(baselines=False))
    assert auto["meta"]["refine"]["preset"] == "auto" and auto["meta"]["refine"]["used"] == "nicp"
    untimed = [
        {k: v for k, v in r["meta"]["pairs"][0]["nicp"].items() if k != "seconds"}
        for r in (auto, nicp)
    ]
    assert untimed[0] == untimed[1]  # the same (deterministic) ICP
    n_nodes = auto["meta"]["consistent_mesh"]["n_vertices"]
    big = register_meshes(prep, RegistrationOptions(baselines=False, nicp_max_nodes=n_nodes - 1))
    assert big["meta"]["refine"]["used"] == "guided" and big["meta"]["pairs"][0]["nicp"] is None
    assert big["meta"]["pairs"][0]["static_correspondences"] == g["static_correspondences"]
    n = nicp["meta"]["pairs"][0]
    assert 0 < n["nicp"]["correspondences"] <= n["nicp"]["candidates"]
    # every candidate node takes its own closest point where that folds nothing
    assert 0 < n["nicp"]["dense_nodes"] <= n["nicp"]["candidates"]
    assert nicp["meta"]["composite_folded_triangles"]["main"] == [0]
    # its fit is Tikhonov-smoothed (extra_regularization): landmarks met to ~1e-5 here
    assert n["folded_triangles"]["dmt"] == 0 and n["E_D"]["dmt"] < 1e-4
    with pytest.raises(ValueError, match="refine"):
        register_meshes(prep, RegistrationOptions(refine="dense"))


def test_extra_correspondences_improve_the_registration():
    from conformorph.geometry.static_correspondences import farthest_point_samples
    from conformorph.pipelines.face_morph import placed_keys

    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)  # same connectivity: vertex j ↔ vertex j is the truth
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    base = register_meshes(prep, RegistrationOptions(refine="none", baselines=False))
    inner = np.flatnonzero(np.linalg.norm(prep[0]["uv"], axis=1) < 0.9)
    ids = farthest_point_samples(prep[0]["Vn"], 60, candidates=inner)
    extra = [(prep[0]["uv"][ids], prep[1]["uv"][ids])]
    reg = register_meshes(prep, RegistrationOptions(baselines=False), extra_correspondences=extra)
    pm = reg["meta"]["pairs"][0]
    assert pm["extra_correspondences"] == 60 and not pm["extra_rejected"]
    assert pm["static_correspondences"] == []  # extra correspondences replace `refine`
    assert pm["folded_triangles"]["dmt"] == 0 and pm["E_D"]["dmt"] < 1e-4

    def err(r):
        return np.sqrt(np.mean(np.sum((placed_keys(r, "main")[1] - V1) ** 2, axis=1)))

    assert err(reg) < 0.75 * err(base)  # measured: 8.5e-3 against 1.35e-2
    with pytest.raises(ValueError, match="one \\(source, target\\) pair"):
        register_meshes(prep, RegistrationOptions(baselines=False), extra_correspondences=extra * 2)
    with pytest.raises(ValueError, match="extra correspondences of pair 1"):
        register_meshes(
            prep,
            RegistrationOptions(baselines=False),
            extra_correspondences=[(extra[0][0], extra[0][1][:5])],
        )


def test_to_first_disk_undoes_the_mobius_chain():
    from conformorph.geometry.mobius_registration import MobiusTransform
    from conformorph.pipelines.face_morph.resampling import to_first_disk

    z = np.array([[0.0, 0.0], [0.3, -0.2], [-0.5, 0.4]])
    M1 = MobiusTransform(0.2 + 0.1j, 0.7)
    M2 = MobiusTransform(-0.1 + 0.05j, -1.9)
    # key 2's disk = M2(M1(key 0's disk)); the inverses of pairs 1, 2 bring it back
    w, jac = to_first_disk(M2.apply(M1.apply(z)), [M1.inverse(), M2.inverse()])
    np.testing.assert_allclose(w, z, atol=1e-12)
    # areas: |d(M2∘M1)/dz|² · jac = 1 (chain rule)
    np.testing.assert_allclose(
        jac * M2.jacobian_determinant(M1.apply(z)) * M1.jacobian_determinant(z), 1.0, rtol=1e-12
    )
    w0, jac0 = to_first_disk(z, [])
    assert np.array_equal(w0, z) and np.all(jac0 == 1.0)


def test_key_disks_do_not_depend_on_how_each_input_disk_is_rotated():
    # a rotated disk map of one input (as a reordered copy can give) must not change
    # the key disk positions D(q, t_i) the homotopy interpolates
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    ref = register_meshes(prep, RegistrationOptions(refine="none", baselines=False))
    c, s = np.cos(1.8), np.sin(1.8)
    Rz = np.array([[c, -s], [s, c]])
    rot = dict(prep[1])
    rot["uv"] = prep[1]["uv"] @ Rz.T
    rot["lm_uv"] = prep[1]["lm_uv"] @ Rz.T
    out = register_meshes([prep[0], rot], RegistrationOptions(refine="none", baselines=False))
    np.testing.assert_allclose(out["key_uv__main"], ref["key_uv__main"], atol=1e-6)
    np.testing.assert_allclose(out["key_lam__main"], ref["key_lam__main"], rtol=1e-5)
    np.testing.assert_allclose(out["key_X__main"], ref["key_X__main"], atol=1e-6)


def test_register_refuses_a_folded_composite_map():
    from conformorph.geometry import disk_conformal_map
    from conformorph.geometry.mesh_errors import FoldedMapError
    from conformorph.pipelines.face_morph import bijectivity_summary

    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = folded_face()  # same faces as mesh 0
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    good = register_meshes(prep, RegistrationOptions(method="identity", baselines=False))
    summary = bijectivity_summary([p["meta"] for p in prep], good["meta"])
    assert summary["folded_triangles"] == 0 and summary["min_jacobian"] > 0
    assert summary["disk_map_folded_before_repair"][1] > 0 and summary["fallbacks"] == []
    # a stage-1 result whose disk map folds (e.g. an edited stage file): the oracle
    # correspondence carries the fold into the composite map, which is refused
    folded = dict(prep[1])
    folded["uv"], info = disk_conformal_map(prep[1]["Vn"], F1, fold_policy="report")
    assert info.flipped == 2
    with pytest.raises(FoldedMapError, match="to key 1 \\(mesh 1\\) folds 2 of the"):
        register_meshes([prep[0], folded], RegistrationOptions(method="identity", baselines=False))


def test_key_disk_positions_are_the_composite_images_not_snapped_to_chords():
    # a fine source rim against a coarse target rim: the target disk mesh covers only
    # the polygon of its 20·2 boundary chords, and the source's boundary nodes land on
    # the circle between them; their key disk positions must stay on the circle (snapping
    # them onto the chords collapses the chord–arc slivers and folds the rim)
    from conformorph.geometry import boundary_loop, flipped_triangles

    V0, F0, lm0 = face_mesh(0.0, levels=4)
    V1, F1, lm1 = face_mesh(1.0, levels=1)
    prepared = [prepare_mesh(V0, F0, lm0, mesh_index=0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    reg = register_meshes(prepared, RegistrationOptions(method="dmt", baselines=False))
    b = boundary_loop(reg["cm_F"])
    key = reg["key_uv__main"][1]
    np.testing.assert_allclose(np.hypot(*key[b].T), 1.0, atol=1e-9)
    assert not flipped_triangles(key, reg["cm_F"]).any()
    # the target's own rim is a coarse polygon: the sliver is real
    rim = prepared[1]["uv"][boundary_loop(prepared[1]["F"])]
    assert len(rim) < len(b) / 4


def test_landmark_motion_is_affine_with_four_spatial_landmarks_else_constant():
    from conformorph.pipelines.face_morph import landmark_motion

    rng = np.random.default_rng(3)
    A = np.array([[1.1, 0.2, 0.0], [-0.1, 0.9, 0.3], [0.05, 0.0, 1.2]])
    c = np.array([0.3, -0.2, 0.1])
    src = rng.random((4, 3))
    at = rng.random((20, 3))
    d, deg = landmark_motion(src, src @ A.T + c, at)
    assert deg == 1  # an affine motion of space is reproduced everywhere
    np.testing.assert_allclose(d, at @ A.T + c - at, atol=1e-9)
    # three landmarks (the fewest allowed) and coplanar ones cannot fix an affine part
    for pts in (src[:3], np.c_[rng.random((6, 2)), np.full(6, 0.4)]):
        dst = pts + rng.normal(0, 0.05, pts.shape)
        d, deg = landmark_motion(pts, dst, pts)
        assert deg == 0
        np.testing.assert_allclose(d, dst - pts, atol=1e-10)  # still exact at the landmarks
    with pytest.raises(ValueError, match="m ≥ 1"):
        landmark_motion(src, src[:3], at)


def test_consistency_check_estimates_the_round_trip_of_every_pair():
    """Issue 27: the forward-backward estimate of the correspondence error is reported
    per pair when asked (and costs nothing when not); identical keys come back home."""
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    off = register_meshes(prep, RegistrationOptions(baselines=False))
    assert off["meta"]["correspondence_estimate"] == [None]
    on = register_meshes(prep, RegistrationOptions(baselines=False, consistency_check=True))
    (est,) = on["meta"]["correspondence_estimate"]
    assert est == on["meta"]["pairs"][0]["correspondence_estimate"]
    assert 0 <= est["median"] <= est["mean"] <= est["max"] and est["p95"] <= est["max"]
    assert est["diameter"] == pytest.approx(prep[0]["meta"]["diameter"])
    assert est["mean"] < 0.01  # a smooth pair comes back to within 1 % of its size
    # the forward registration itself is the same with and without the check
    np.testing.assert_array_equal(on["key_X__main"], off["key_X__main"])
    same = [prepare_mesh(V0, F0, lm0), prepare_mesh(V0, F0, lm0, mesh_index=1)]
    home = register_meshes(same, RegistrationOptions(baselines=False, consistency_check=True))
    assert home["meta"]["correspondence_estimate"][0]["max"] < 1e-6
