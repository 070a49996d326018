"""One test per step function of conformorph.pipelines.face_morph that computes something checkable."""

import inspect

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conformorph.pipelines.face_morph import (
    DEFAULT_CURVATURE,
    NICP_AUTO_MAX_NODES,
    NICP_CORRESPONDENCES,
    NICP_TOL,
    ExportOptions,
    FaceMorphOptions,
    FrameOptions,
    KeyOptions,
    RegistrationOptions,
    bijectivity_summary,
    morph_metrics,
    prepare_mesh,
)
from conformorph.pipelines.face_morph.dense_refinement import resolve_refine
from conformorph.pipelines.face_morph.disk_registration import (
    KeyPair,
    landmark_dmt,
    mobius_registration,
)
from conformorph.pipelines.face_morph.resampling import composite_fold_check, safe_conformal_factor
from conformorph.pipelines.face_morph.rigid_alignment import align_keys, input_similarities
from conformorph.pipelines.face_morph.run import key_and_frame_times

from .face_fixtures import face_mesh

#: the keyword defaults of the former register_meshes / compute_frames / export_outputs /
#: run_face_morph (pipelines/face_morph_pipeline.py before the split)
FORMER_REGISTRATION_DEFAULTS = {
    "method": "dmt",
    "consistent": "source",
    "target_vertices": None,
    "icp_iterations": 10,
    "baselines": True,
    "curvature_source": "consistent",
    "refine": "auto",
    "static_refinement": None,
    "static_tol": None,
    "static_samples": 400,
    "static_max_disk_offset": 0.05,
    "static_min_separation": 0.02,
    "static_guided": None,
    "extra_regularization": 1e-8,
    "nicp_correspondences": 1000,
    "nicp_tol": 2e-3,
    "nicp_max_nodes": 20_000,
}


def test_options_defaults_equal_the_former_keyword_defaults():
    r = RegistrationOptions()
    assert {k: getattr(r, k) for k in FORMER_REGISTRATION_DEFAULTS} == FORMER_REGISTRATION_DEFAULTS
    assert (NICP_CORRESPONDENCES, NICP_TOL, NICP_AUTO_MAX_NODES) == (1000, 2e-3, 20_000)
    assert FrameOptions() == FrameOptions(curvature="screened", key_metrics=True)
    assert DEFAULT_CURVATURE == "screened"
    assert ExportOptions() == ExportOptions(per_frame=False, sparse=False, normals=True)
    assert KeyOptions() == KeyOptions(fill_holes=False, remove_ears=False, disk_method="fast")
    o = FaceMorphOptions()
    assert (o.times, o.frames, o.frame_times, o.write_glb) == (None, 30, None, True)
    assert o.registration == r and o.homotopy == FrameOptions() and o.export == ExportOptions()
    # every options class is frozen
    with pytest.raises(AttributeError):
        r.method = "mt"  # type: ignore[misc]
    # no step takes more than 10 parameters
    import conformorph.pipelines.face_morph as fm

    for name in fm.__all__:
        obj = getattr(fm, name)
        if inspect.isfunction(obj):
            assert len(inspect.signature(obj).parameters) <= 10, name


def _two_keys():
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    return [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]


def test_rigid_alignment_recovers_a_known_rotation():
    prep = _two_keys()
    R = Rotation.from_rotvec([0.2, -0.4, 0.3]).as_matrix()
    t = np.array([0.1, -0.2, 0.05])
    moved = dict(prep[0])  # key 0 itself, rotated and shifted: aligned back exactly
    moved["Vn"] = prep[0]["Vn"] @ R.T + t
    moved["lm_points"] = prep[0]["lm_points"] @ R.T + t
    rigid = align_keys([prep[0], moved], icp_iterations=10)
    np.testing.assert_allclose(rigid.rotations[1], R.T, atol=1e-9)
    np.testing.assert_allclose(rigid.aligned(1, moved["Vn"]), prep[0]["Vn"], atol=1e-9)
    assert rigid.meta[0]["n_rigid_landmarks"] == prep[0]["lm_points"].shape[0]
    # the similarity back to the input undoes the normalisation and the alignment
    S = input_similarities([prep[0], moved], rigid)
    X_in = S["key_s"][1] * (rigid.aligned(1, moved["Vn"]) @ S["key_R"][1].T) + S["key_t"][1]
    N = moved["Vn"] * moved["norm_scale"] + moved["norm_translation"]
    np.testing.assert_allclose(X_in, N, atol=1e-9)


def test_composite_fold_check_refuses_a_folded_map_and_reports_the_baseline():
    from conformorph.geometry.mesh_errors import FoldedMapError

    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    good = uv * 0.5
    folded = uv.copy()
    folded[3] = [0.2, 0.2]  # vertex 3 pushed through edge (1, 2): triangle 1 flips
    folds, jac = composite_fold_check(uv, [uv, good, folded], F)
    assert folds == [0, 1] and jac[0] == pytest.approx(0.25) and jac[1] < 0
    with pytest.raises(FoldedMapError, match="to key 2 \\(mesh 2\\) folds 1 of the 2"):
        composite_fold_check(uv, [uv, good, folded], F, refuse="dmt")
    assert composite_fold_check(uv, [uv, good], F, refuse="dmt") == ([0], [pytest.approx(0.25)])


def test_safe_conformal_factor_is_the_area_ratio():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    X = np.c_[2.0 * uv, np.zeros(3)]  # the disk scaled by 2: areas × 4
    np.testing.assert_allclose(safe_conformal_factor(X, np.array([[0, 1, 2]]), uv), 4.0)
    with pytest.raises(ValueError, match="zero disk area"):
        safe_conformal_factor(X, np.array([[0, 1, 2]]), np.zeros((3, 2)))


def test_resolve_refine_presets_and_overrides():
    auto = resolve_refine(RegistrationOptions(), 7000)
    assert (auto.preset, auto.used, auto.rounds, auto.tol, auto.guided) == (
        "auto",
        "nicp",
        0,
        3e-3,
        False,
    )
    big = resolve_refine(RegistrationOptions(), NICP_AUTO_MAX_NODES + 1)
    assert (big.used, big.rounds, big.tol, big.guided) == ("guided", 1, 5e-3, True)
    static = resolve_refine(RegistrationOptions(refine="static", static_tol=1e-2), 10)
    assert (static.rounds, static.tol, static.guided) == (1, 1e-2, False)
    with pytest.raises(ValueError, match="refine"):
        resolve_refine(RegistrationOptions(refine="dense"), 10)


def test_pair_registration_dmt_meets_the_landmarks_mt_does_not():
    from conformorph.geometry.point_location import PointLocator

    a, b = _two_keys()
    loc_a, loc_b = PointLocator(a["uv"], a["F"]), PointLocator(b["uv"], b["F"])
    pair = KeyPair(1, a, b, a["Vn"], b["Vn"], loc_a, loc_b, a["lm_points"], b["lm_points"])
    # kernel_scale: λ of the target over λ of the source at corresponding points
    s = pair.kernel_scale(a["lm_uv"], b["lm_uv"])
    lam_a = loc_a.locate(a["lm_uv"]).interpolate(a["F"], a["lam"])
    lam_b = loc_b.locate(b["lm_uv"]).interpolate(b["F"], b["lam"])
    np.testing.assert_allclose(s, lam_b / lam_a)
    dmt = landmark_dmt(pair, a["uv"], a["F"])
    mt = mobius_registration(pair, a["uv"], a["F"])
    err_d = np.abs(dmt.apply(a["lm_uv"]) - b["lm_uv"]).max()
    err_m = np.abs(mt.apply(a["lm_uv"]) - b["lm_uv"]).max()
    assert err_d < 1e-8 < err_m and dmt.fold.n_folded == 0


def test_key_and_frame_times():
    kt, ft = key_and_frame_times(3, FaceMorphOptions(frames=5))
    np.testing.assert_array_equal(kt, [0.0, 1.0, 2.0])
    np.testing.assert_allclose(ft, [0.0, 0.5, 1.0, 1.5, 2.0])
    kt, ft = key_and_frame_times(2, FaceMorphOptions(times=(0.0, 2.0), frame_times=(-1.0, 3.0)))
    np.testing.assert_array_equal(ft, [-1.0, 3.0])  # explicit, may extrapolate
    with pytest.raises(ValueError, match="--times needs 3"):
        key_and_frame_times(3, FaceMorphOptions(times=(0.0, 1.0)))
    with pytest.raises(ValueError, match="strictly increasing"):
        key_and_frame_times(2, FaceMorphOptions(frame_times=(1.0, 1.0)))


def test_morph_metrics_document_sums_the_folds_and_lists_the_fallbacks():
    inputs = [
        {"disk_map": {"flipped": 0, "flipped_before_repair": 2}},
        {"disk_map": {"flipped": 0, "flipped_before_repair": 0}},
    ]
    reg = {
        "registration": "dmt",
        "composite_folded_triangles": {"main": [0]},
        "composite_min_jacobian": {"main": [0.3]},
        "pairs": [{"pair": [0, 1], "dmt_fallback": "stepwise"}],
    }
    doc = morph_metrics(
        inputs, reg, np.array([0.0, 1.0]), np.array([0.0, 0.5, 1.0]), {}, {}, {"total": 1.0}
    )
    assert doc["bijectivity"] == bijectivity_summary(inputs, reg)
    assert doc["bijectivity"]["folded_triangles"] == 0
    assert doc["bijectivity"]["min_jacobian"] == 0.3
    assert [f["fallback"] for f in doc["bijectivity"]["fallbacks"]] == ["stepwise"]
    assert doc["key_times"] == [0.0, 1.0] and doc["frame_times"] == [0.0, 0.5, 1.0]


def test_key_frame_metrics_from_the_delivered_frames_equal_a_fresh_solve(tmp_path):
    from dataclasses import replace

    from conformorph.pipelines.face_morph import FaceMorphOptions, compute_frames, register_meshes
    from conformorph.pipelines.face_morph.metrics import delivered_key_frames, key_frame_metrics
    from conformorph.pipelines.face_morph.run import _prepare_keys

    from .face_morph_inputs import face_inputs

    paths, L = face_inputs(tmp_path, smiles=(0.0, 1.0))
    opts = FaceMorphOptions(frames=20)
    prepared = _prepare_keys(paths, L, None, opts)
    reg = register_meshes(prepared, opts.registration)
    meshes = [(p["V"], p["F"]) for p in prepared]
    kt, ft = key_and_frame_times(2, opts)
    fr = compute_frames(reg, meshes, kt, ft, replace(opts.homotopy, key_metrics=False))
    curvature = opts.homotopy.curvature
    Vk = delivered_key_frames(fr, kt)
    assert Vk is not None and Vk.shape == (2, *fr["frames_V"].shape[1:])
    np.testing.assert_array_equal(Vk, fr["frames_V"][[0, -1]])
    # the same numbers as solving the key frames again, to the bit
    assert key_frame_metrics(reg, meshes, kt, curvature, frames=fr) == key_frame_metrics(
        reg, meshes, kt, curvature
    )
    # a key time that is no frame time: nothing delivered (the metrics solve again)
    assert delivered_key_frames(fr, np.array([0.0, 0.99])) is None
    assert delivered_key_frames(None, kt) is None
