import json

import numpy as np
import pytest

from conformorph.pipelines.face_morph import (
    InputMismatchError,
)

from .face_fixtures import face_mesh, write_obj
from .face_morph_inputs import (
    SHARED,
    face_inputs,
    morph,
    validate_glb,
)


def test_end_to_end_outputs_and_metrics(tmp_path):
    paths, L = face_inputs(tmp_path, smiles=(0.0, 1.0, 0.3))
    out = tmp_path / "out"
    seen = []
    m = morph(paths, L, out, frames=7, per_frame=True, progress=lambda f, s: seen.append(f))
    assert (out / "animation.glb").stat().st_size > 0
    assert sorted(p.name for p in (out / "frames").iterdir()) == [f"{k:03d}.glb" for k in range(7)]
    assert json.loads((out / "metrics.json").read_text()) == m
    assert m["frame_times"] == pytest.approx(np.linspace(0, 2, 7).tolist())
    assert seen == sorted(seen) and seen[-1] == 1.0
    pairs = m["registration"]["pairs"]
    assert len(pairs) == 2
    for p in pairs:
        assert p["E_D"]["dmt"] < p["E_D"]["mt"] and p["E"]["dmt"] < p["E"]["mt"]
        assert p["folded_triangles"]["dmt"] == 0
    km = m["frames"]["key_frame_L2_to_inputs"]
    assert max(km["dmt"]) < 0.02 and km["linear"][0] < 1e-12
    assert "exact" in m["frames"]["linear_baseline_note"]
    for k in ("maps", "registration", "frames", "export", "total"):
        assert m["seconds"][k] >= 0
    validate_glb([out / "animation.glb", out / "frames" / "000.glb", out / "frames" / "006.glb"])


def test_reordered_and_refined_inputs_give_the_same_quality(tmp_path):
    (tmp_path / "a").mkdir()
    base, L0 = face_inputs(tmp_path / "a")
    m0 = morph(base, L0, tmp_path / "o0", frames=3, write_glb=False)
    (tmp_path / "b").mkdir()
    other, L1 = face_inputs(tmp_path / "b", reorder_last=True)
    m1 = morph(other, L1, tmp_path / "o1", frames=3, write_glb=False)
    k0 = m0["frames"]["key_frame_L2_to_inputs"]["dmt"]
    k1 = m1["frames"]["key_frame_L2_to_inputs"]["dmt"]
    np.testing.assert_allclose(k1, k0, rtol=1e-6, atol=1e-9)  # reordering changes nothing
    (tmp_path / "c").mkdir()
    fine, L2 = face_inputs(tmp_path / "c", subdivide_first=True)
    m2 = morph(fine, L2, tmp_path / "o2", frames=3, write_glb=False)
    k2 = m2["frames"]["key_frame_L2_to_inputs"]["dmt"]
    assert max(k2) < 2.0 * max(k0) + 1e-3


def test_identity_needs_shared_faces(tmp_path):
    paths, L = face_inputs(tmp_path, reorder_last=True)
    with pytest.raises(InputMismatchError, match="share"):
        morph(paths, L, tmp_path / "o", method="identity", frames=2, write_glb=False)
    paths, L = face_inputs(tmp_path)
    m = morph(paths, L, tmp_path / "o", method="identity", frames=2, write_glb=False)
    assert m["registration"]["registration"] == "identity"


def test_linear_method_is_exact_at_keys_and_badface_inputs(tmp_path):
    paths, L = face_inputs(tmp_path)
    m = morph(paths, L, tmp_path / "o", method="linear", frames=3)
    assert max(m["frames"]["key_frame_L2_to_inputs"]["linear"]) < 1e-2
    with pytest.raises(ValueError, match="times"):
        morph(paths, L, tmp_path / "o", times=[1.0, 0.0], write_glb=False)
    with pytest.raises(ValueError, match="method"):
        morph(paths, L, tmp_path / "o", method="tps", write_glb=False)


@pytest.mark.shared_data
@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data absent")
def test_ict_neutral_to_smile_dmt_close_to_oracle(tmp_path):
    lm = json.loads((SHARED / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": [lm, lm]}))
    from conformorph.pipelines.mesh_io import read_mesh

    N, F = read_mesh(SHARED / "ict_generic_neutral.obj")
    S, _ = read_mesh(SHARED / "ict_generic_smile.obj")
    truth = tmp_path / "half.obj"
    write_obj(truth, 0.5 * (N + S), F)
    paths = [SHARED / "ict_generic_neutral.obj", SHARED / "ict_generic_smile.obj"]
    err = {}
    for method in ("identity", "dmt"):
        m = morph(
            paths,
            L,
            tmp_path / method,
            method=method,
            frames=2,
            write_glb=False,
            truths=[(0.5, truth)],
            key_metrics=False,
        )
        err[method] = m["frames"]["truth_errors"]
    # measured: identity 2.5e-3, DMT 3.9e-3, MT ~2e-2 (relative L2 to the true half blend)
    assert err["identity"]["identity"][0]["L2"] < 4e-3
    assert err["dmt"]["dmt"][0]["L2"] < 2.0 * err["identity"]["identity"][0]["L2"]
    assert err["dmt"]["dmt"][0]["L2"] < 0.5 * err["dmt"]["mt"][0]["L2"]


def test_remove_ears_translates_landmarks(tmp_path):
    from conformorph.geometry import boundary_loop
    from conformorph.pipelines.landmarks_io import LandmarkIndexError

    paths, lms = [], []
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s)
        b = boundary_loop(F)
        a, c = int(b[0]), int(b[1])  # boundary half-edge a → c of some face
        ear = 1.05 * (V[a] + V[c]) / 2
        V = np.vstack([V, ear])
        F = np.vstack([F, [c, a, V.shape[0] - 1]])
        paths.append(write_obj(tmp_path / f"e{i}.obj", V, F))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    with pytest.raises(ValueError, match="ear"):
        morph(paths, L, tmp_path / "o0", frames=2, write_glb=False)
    m = morph(paths, L, tmp_path / "o", frames=2, write_glb=False, remove_ears=True)
    assert m["inputs"][0]["n_vertices"] == face_mesh(0.0)[0].shape[0]
    bad = tmp_path / "bad.json"
    ear_id = face_mesh(0.0)[0].shape[0]
    bad.write_text(json.dumps({"landmarks": [lms[0][:-1] + [ear_id], lms[1]]}))
    with pytest.raises(LandmarkIndexError, match="ear"):
        morph(paths, bad, tmp_path / "o1", frames=2, write_glb=False, remove_ears=True)


def test_three_landmarks_morph_end_to_end(tmp_path):
    # m = 3 is the fewest landmarks the issue allows; both refinements must work with them
    paths, lms = [], []
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s)
        paths.append(write_obj(tmp_path / f"m{i}.obj", V, F))
        lms.append([lm[0], lm[1], lm[5]])  # the eyes and the chin
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    m = morph(paths, L, tmp_path / "o", frames=3, refine="nicp")
    (pair,) = m["registration"]["pairs"]
    # the refine="nicp" fit is Tikhonov-smoothed: landmarks met to ~1e-6, not exactly
    assert pair["folded_triangles"]["dmt"] == 0 and pair["E_D"]["dmt"] < 1e-4
    assert pair["nicp"]["correspondences"] > 0
    assert max(m["frames"]["key_frame_L2_to_inputs"]["dmt"]) < 0.02
    validate_glb([tmp_path / "o" / "animation.glb"])
    g = morph(paths, L, tmp_path / "g", frames=3, refine="guided", write_glb=False)
    (pair,) = g["registration"]["pairs"]
    assert pair["guide_polynomial_degree"] == 0  # constant plus r kernel with 3 landmarks
    assert pair["static_correspondences"][0] > 0
    assert pair["folded_triangles"]["dmt"] == 0 and pair["E_D"]["dmt"] < 1e-8


def test_base_normals_always_normal_targets_by_default(tmp_path):
    from pygltflib import GLTF2

    from conformorph.geometry.vertex_normals import vertex_normals

    from .test_export_gltf import read_accessor

    paths, L = face_inputs(tmp_path)
    out = tmp_path / "o"
    morph(paths, L, out, frames=3, per_frame=True, key_metrics=False)  # default: normals
    g = GLTF2().load(str(out / "animation.glb"))
    prim = g.meshes[0].primitives[0]
    base = read_accessor(g, prim.attributes.POSITION).astype(np.float64)
    N0 = read_accessor(g, prim.attributes.NORMAL)
    np.testing.assert_allclose(np.linalg.norm(N0, axis=1), 1.0, atol=1e-6)
    F = read_accessor(g, prim.indices).reshape(-1, 3).astype(np.int64)
    for tgt in prim.targets:
        P = base + read_accessor(g, tgt["POSITION"])
        N = N0 + read_accessor(g, tgt["NORMAL"])  # the frame's own normals, base + delta
        np.testing.assert_allclose(N, vertex_normals(P, F), atol=1e-4)
    fg = GLTF2().load(str(out / "frames" / "001.glb"))
    assert fg.meshes[0].primitives[0].attributes.NORMAL is not None
    validate_glb([out / "animation.glb", out / "frames" / "001.glb"])
    # --no-normals: position-only targets over the base mesh's static smooth normals
    # (without NORMAL, Blender shades flat)
    morph(paths, L, tmp_path / "p", frames=3, normals=False, per_frame=True, key_metrics=False)
    g = GLTF2().load(str(tmp_path / "p" / "animation.glb"))
    prim = g.meshes[0].primitives[0]
    assert all(t.get("NORMAL") is None for t in prim.targets)
    base = read_accessor(g, prim.attributes.POSITION).astype(np.float64)
    N0 = read_accessor(g, prim.attributes.NORMAL).astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(N0, axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(N0, vertex_normals(base, F), atol=1e-4)  # base read back in float32
    for k in range(3):
        fg = GLTF2().load(str(tmp_path / "p" / "frames" / f"{k:03d}.glb"))
        fp = fg.meshes[0].primitives[0]
        P = read_accessor(fg, fp.attributes.POSITION).astype(np.float64)
        Nk = read_accessor(fg, fp.attributes.NORMAL).astype(np.float64)
        np.testing.assert_allclose(Nk, vertex_normals(P, F), atol=1e-4)
    validate_glb([tmp_path / "p" / "animation.glb", tmp_path / "p" / "frames" / "002.glb"])
