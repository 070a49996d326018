import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from pipelines.face_morph_pipeline import (
    InputMismatchError,
    load_stage,
    prepare_mesh,
    register_meshes,
    run_face_morph,
    save_stage,
)

from .face_fixtures import face_mesh, write_obj

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data" / "faces"


def _inputs(tmp_path, smiles=(0.0, 1.0), reorder_last=False, subdivide_first=False):
    paths, lms = [], []
    for i, s in enumerate(smiles):
        V, F, lm = face_mesh(s, levels=4 if (subdivide_first and i == 0) else 3)
        if reorder_last and i == len(smiles) - 1:
            perm = np.random.default_rng(5).permutation(V.shape[0])
            inv = np.argsort(perm)
            V, F, lm = V[perm], inv[F], [int(inv[j]) for j in lm]
        paths.append(write_obj(tmp_path / f"m{i}.obj", V, F))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    return paths, L


def _validate(files):
    node = shutil.which("node")
    if node is None or not (ROOT / "node_modules" / "gltf-validator").is_dir():
        pytest.skip("node / npm gltf-validator not installed")
    proc = subprocess.run(
        [node, str(ROOT / "tools" / "gltf_validate.mjs"), *map(str, files)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    reports = [json.loads(x) for x in proc.stdout.splitlines() if x.startswith("{")]
    assert len(reports) == len(files), proc.stderr
    for r in reports:
        assert (r["errors"], r["warnings"]) == (0, 0), r


def test_end_to_end_outputs_and_metrics(tmp_path):
    paths, L = _inputs(tmp_path, smiles=(0.0, 1.0, 0.3))
    out = tmp_path / "out"
    seen = []
    m = run_face_morph(
        paths, L, out, frames=7, per_frame=True, progress=lambda f, s: seen.append(f)
    )
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
    _validate([out / "animation.glb", out / "frames" / "000.glb", out / "frames" / "006.glb"])


def test_reordered_and_refined_inputs_give_the_same_quality(tmp_path):
    (tmp_path / "a").mkdir()
    base, L0 = _inputs(tmp_path / "a")
    m0 = run_face_morph(base, L0, tmp_path / "o0", frames=3, write_glb=False)
    (tmp_path / "b").mkdir()
    other, L1 = _inputs(tmp_path / "b", reorder_last=True)
    m1 = run_face_morph(other, L1, tmp_path / "o1", frames=3, write_glb=False)
    k0 = m0["frames"]["key_frame_L2_to_inputs"]["dmt"]
    k1 = m1["frames"]["key_frame_L2_to_inputs"]["dmt"]
    np.testing.assert_allclose(k1, k0, rtol=1e-6, atol=1e-9)  # reordering changes nothing
    (tmp_path / "c").mkdir()
    fine, L2 = _inputs(tmp_path / "c", subdivide_first=True)
    m2 = run_face_morph(fine, L2, tmp_path / "o2", frames=3, write_glb=False)
    k2 = m2["frames"]["key_frame_L2_to_inputs"]["dmt"]
    assert max(k2) < 2.0 * max(k0) + 1e-3


def test_identity_needs_shared_faces(tmp_path):
    paths, L = _inputs(tmp_path, reorder_last=True)
    with pytest.raises(InputMismatchError, match="share"):
        run_face_morph(paths, L, tmp_path / "o", method="identity", frames=2, write_glb=False)
    paths, L = _inputs(tmp_path)
    m = run_face_morph(paths, L, tmp_path / "o", method="identity", frames=2, write_glb=False)
    assert m["registration"]["registration"] == "identity"


def test_linear_method_is_exact_at_keys_and_bad_inputs(tmp_path):
    paths, L = _inputs(tmp_path)
    m = run_face_morph(paths, L, tmp_path / "o", method="linear", frames=3)
    assert max(m["frames"]["key_frame_L2_to_inputs"]["linear"]) < 1e-2
    with pytest.raises(ValueError, match="times"):
        run_face_morph(paths, L, tmp_path / "o", times=[1.0, 0.0], write_glb=False)
    with pytest.raises(ValueError, match="method"):
        run_face_morph(paths, L, tmp_path / "o", method="tps", write_glb=False)


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


@pytest.mark.shared_data
@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data absent")
def test_ict_neutral_to_smile_dmt_close_to_oracle(tmp_path):
    lm = json.loads((SHARED / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": [lm, lm]}))
    from pipelines.mesh_io import read_mesh

    N, F = read_mesh(SHARED / "ict_generic_neutral.obj")
    S, _ = read_mesh(SHARED / "ict_generic_smile.obj")
    truth = tmp_path / "half.obj"
    write_obj(truth, 0.5 * (N + S), F)
    paths = [SHARED / "ict_generic_neutral.obj", SHARED / "ict_generic_smile.obj"]
    err = {}
    for method in ("identity", "dmt"):
        m = run_face_morph(
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


def test_refine_presets():
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    paper = register_meshes(prep, refine="none", baselines=False)
    assert paper["meta"]["pairs"][0]["static_correspondences"] == []
    guided = register_meshes(prep, refine="guided", baselines=False)
    g = guided["meta"]["pairs"][0]
    assert guided["meta"]["refine"]["guided"] is True
    assert len(g["static_correspondences"]) == 1
    assert g["folded_triangles"]["dmt"] == 0
    # landmarks stay matched exactly whatever the extra correspondences did
    assert g["E_D"]["dmt"] < 1e-8
    nicp = register_meshes(prep, baselines=False, refine="nicp")
    assert nicp["meta"]["refine"]["preset"] == nicp["meta"]["refine"]["used"] == "nicp"
    # the default, auto: nicp on this small consistent mesh, guided above the node budget
    auto = register_meshes(prep, baselines=False)
    assert auto["meta"]["refine"]["preset"] == "auto" and auto["meta"]["refine"]["used"] == "nicp"
    untimed = [
        {k: v for k, v in r["meta"]["pairs"][0]["nicp"].items() if k != "seconds"}
        for r in (auto, nicp)
    ]
    assert untimed[0] == untimed[1]  # the same (deterministic) ICP
    n_nodes = auto["meta"]["consistent_mesh"]["n_vertices"]
    big = register_meshes(prep, baselines=False, nicp_max_nodes=n_nodes - 1)
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
        register_meshes(prep, refine="dense")


def _write_textured_obj(path, V, F, uv):
    lines = [f"v {a:.17g} {b:.17g} {c:.17g}" for a, b, c in V]
    lines += [f"vt {a:.17g} {b:.17g}" for a, b in uv]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")
    return path


def _gradient_image(h, w, blue):
    """R = u, G = v (OBJ convention, v up), B = blue: linear, so bilinear sampling is exact."""
    r, c = np.mgrid[0:h, 0:w]
    u, v = (c + 0.5) / w, 1.0 - (r + 0.5) / h
    return np.stack([u, v, np.full_like(u, blue)], axis=2)


def _textured_inputs(tmp_path, reorder_last=False):
    """Two textured faces: mesh 1's UVs and image are mirrored left-right (a different
    layout of the same picture) and its blue channel is 1 where mesh 0's is 0."""
    from PIL import Image

    paths, lms, imgs = [], [], []
    V0 = face_mesh(0.0)[0]
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s)
        uv = 0.5 + 0.45 * V0[:, :2]  # vertex j shows the same texel on both (before mirroring)
        img = _gradient_image(32, 40, blue=float(i))
        if i == 1:
            uv[:, 0] = 1.0 - uv[:, 0]
            img = img[:, ::-1]
            if reorder_last:
                perm = np.random.default_rng(5).permutation(V.shape[0])
                inv = np.argsort(perm)
                V, F, lm, uv = V[perm], inv[F], [int(inv[j]) for j in lm], uv[perm]
        paths.append(_write_textured_obj(tmp_path / f"t{i}.obj", V, F, uv))
        lms.append(lm)
        imgs.append(tmp_path / f"tex{i}.png")
        Image.fromarray(np.rint(img * 255).astype(np.uint8)).save(imgs[-1])
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    return paths, L, imgs


def _glb_texture(path):
    import io

    from PIL import Image
    from pygltflib import GLTF2

    g = GLTF2().load(str(path))
    bv = g.bufferViews[g.images[0].bufferView]
    data = g.binary_blob()[bv.byteOffset : bv.byteOffset + bv.byteLength]
    return g, np.asarray(Image.open(io.BytesIO(data)).convert("RGB"), dtype=np.float64) / 255


def test_textures_are_resampled_onto_one_atlas_and_cross_faded(tmp_path):
    from .test_export_gltf import read_accessor

    paths, L, imgs = _textured_inputs(tmp_path)
    out = tmp_path / "o"
    m = run_face_morph(
        paths,
        L,
        out,
        frames=3,
        textures=imgs,
        method="identity",
        per_frame=True,
        key_metrics=False,
    )
    tex = m["registration"]["texture"]
    assert tex["size"] == [32, 40] and 0.3 < tex["coverage"] < 1.0
    assert m["registration"]["appearance"]["source"] == "texture"
    expect = [_gradient_image(32, 40, 0.0), _gradient_image(32, 40, 0.5)]
    expect.append(_gradient_image(32, 40, 1.0))
    # texels inside mesh 0's UV disk (centre 0.5, radius 0.45); outside them, padding
    r, c = np.mgrid[0:32, 0:40]
    inside = np.hypot((c + 0.5) / 40 - 0.5, 1 - (r + 0.5) / 32 - 0.5) < 0.44
    # every key's texture on mesh 0's layout: mesh 1's mirrored picture comes back unmirrored
    from PIL import Image

    for i in (0, 1):
        key = np.asarray(Image.open(out / "textures" / f"key_{i:03d}.png"), dtype=float) / 255
        np.testing.assert_allclose(key[inside], expect[2 * i][inside], atol=1.5 / 255)
    # per-frame GLBs carry their own blend (t = 0.5: blue 0.5); the animation frame 0's
    g, t0 = _glb_texture(out / "animation.glb")
    np.testing.assert_allclose(t0[inside], expect[0][inside], atol=1.5 / 255)
    prim = g.meshes[0].primitives[0]
    assert prim.attributes.COLOR_0 is None  # it would multiply the texture
    from pipelines.mesh_io import read_mesh

    V0, _ = read_mesh(paths[0])
    uv0 = 0.5 + 0.45 * V0[:, :2]
    np.testing.assert_allclose(
        read_accessor(g, prim.attributes.TEXCOORD_0), np.c_[uv0[:, 0], 1 - uv0[:, 1]], atol=1e-6
    )
    for k in range(3):
        _, tk = _glb_texture(out / "frames" / f"{k:03d}.glb")
        np.testing.assert_allclose(tk[inside], expect[k][inside], atol=1.5 / 255)
    _validate([out / "animation.glb", out / "frames" / "001.glb"])


def test_textures_through_dmt_with_other_connectivity_and_landmark_mesh(tmp_path):
    from PIL import Image

    paths, L, imgs = _textured_inputs(tmp_path, reorder_last=True)
    out = tmp_path / "o"
    m = run_face_morph(
        paths, L, out, frames=2, textures=imgs, consistent="landmarks", key_metrics=False
    )
    assert m["registration"]["consistent_mesh"]["mode"] == "landmarks"
    k0, k1 = (
        np.asarray(Image.open(out / "textures" / f"key_{i:03d}.png"), dtype=float) / 255
        for i in (0, 1)
    )
    # the DMT correspondence is not the identity (the mouth moves), but close: R, G agree
    err = np.abs(k1[..., :2] - k0[..., :2])
    assert np.median(err) < 0.01 and err.max() < 0.1
    assert np.all(k1[..., 2] > 0.99) and np.all(k0[..., 2] < 0.01)
    _validate([out / "animation.glb"])
    # a mesh without texture coordinates cannot take a texture: a clear error
    V, F, lm = face_mesh(0.0)
    plain = write_obj(tmp_path / "plain.obj", V, F)
    with pytest.raises(ValueError, match="texture coordinate"):
        run_face_morph([plain, paths[1]], L, tmp_path / "o2", textures=imgs, write_glb=False)


def _write_coloured_obj(path, V, F, C):
    lines = [
        f"v {a:.17g} {b:.17g} {c:.17g} {r:.6f} {g:.6f} {b2:.6f}"
        for (a, b, c), (r, g, b2) in zip(V, C, strict=True)
    ]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_vertex_colours_from_the_files_are_resampled_and_cross_fade(tmp_path):
    from pygltflib import GLTF2

    from pipelines.face_morph_pipeline import read_vertex_colors

    from .test_export_gltf import read_accessor

    def colour(V, blue):  # smooth in the face's plane, so corresponding points agree
        return np.c_[0.5 + 0.4 * V[:, 0], 0.5 + 0.4 * V[:, 1], np.full(V.shape[0], blue)]

    paths, lms = [], []
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s)
        C = colour(V, float(i))
        if i == 1:  # another vertex order: colours must follow the registration, not ids
            perm = np.random.default_rng(2).permutation(V.shape[0])
            inv = np.argsort(perm)
            V, F, lm, C = V[perm], inv[F], [int(inv[j]) for j in lm], C[perm]
        paths.append(_write_coloured_obj(tmp_path / f"c{i}.obj", V, F, C))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    C1 = read_vertex_colors(paths[1], 1937)
    assert C1 is not None and C1.shape == (1937, 3) and np.all(C1[:, 2] == 1.0)
    assert read_vertex_colors(write_obj(tmp_path / "plain.obj", *face_mesh(0.0)[:2]), 1937) is None
    out = tmp_path / "o"
    m = run_face_morph(paths, L, out, frames=3, per_frame=True, key_metrics=False)
    assert m["registration"]["appearance"]["source"] == "vertex_colors"
    g = GLTF2().load(str(out / "animation.glb"))
    prim = g.meshes[0].primitives[0]
    base = read_accessor(g, prim.attributes.COLOR_0)
    V0 = face_mesh(0.0)[0]
    np.testing.assert_allclose(base, colour(V0, 0.0), atol=0.6 / 255)  # key 0: its own (8-bit)
    last = base + read_accessor(g, prim.targets[2]["COLOR_0"])
    # key 1's colours resampled at the corresponding points: R, G close to key 0's there
    assert np.abs(last[:, :2] - base[:, :2]).max() < 0.05
    np.testing.assert_allclose(last[:, 2], 1.0, atol=1e-6)
    mid = base + read_accessor(g, prim.targets[1]["COLOR_0"])
    np.testing.assert_allclose(mid, 0.5 * (base + last), atol=1e-5)  # two keys: linear
    f1 = GLTF2().load(str(out / "frames" / "001.glb"))
    np.testing.assert_allclose(
        read_accessor(f1, f1.meshes[0].primitives[0].attributes.COLOR_0), mid, atol=1e-5
    )
    _validate([out / "animation.glb", out / "frames" / "001.glb"])
    # colours in only one input are not used (a cross-fade to nothing): said in the metrics
    plain = write_obj(tmp_path / "p1.obj", *face_mesh(1.0)[:2])
    L2 = tmp_path / "l2.json"
    L2.write_text(json.dumps({"landmarks": [lms[0], face_mesh(1.0)[2]]}))
    m = run_face_morph([paths[0], plain], L2, tmp_path / "o2", frames=2, key_metrics=False)
    app = m["registration"]["appearance"]
    assert app["source"] is None and app["inputs_with_vertex_colors"] == [True, False]
    assert "every input" in app["note"]


def test_remove_ears_translates_landmarks(tmp_path):
    from geometry import boundary_loop
    from pipelines.landmarks_io import LandmarkIndexError

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
        run_face_morph(paths, L, tmp_path / "o0", frames=2, write_glb=False)
    m = run_face_morph(paths, L, tmp_path / "o", frames=2, write_glb=False, remove_ears=True)
    assert m["inputs"][0]["n_vertices"] == face_mesh(0.0)[0].shape[0]
    bad = tmp_path / "bad.json"
    ear_id = face_mesh(0.0)[0].shape[0]
    bad.write_text(json.dumps({"landmarks": [lms[0][:-1] + [ear_id], lms[1]]}))
    with pytest.raises(LandmarkIndexError, match="ear"):
        run_face_morph(paths, bad, tmp_path / "o1", frames=2, write_glb=False, remove_ears=True)


def test_extra_correspondences_improve_the_registration():
    from geometry.static_correspondences import farthest_point_samples
    from pipelines.face_morph_pipeline import _placed_keys

    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)  # same connectivity: vertex j ↔ vertex j is the truth
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    base = register_meshes(prep, refine="none", baselines=False)
    inner = np.flatnonzero(np.linalg.norm(prep[0]["uv"], axis=1) < 0.9)
    ids = farthest_point_samples(prep[0]["Vn"], 60, candidates=inner)
    extra = [(prep[0]["uv"][ids], prep[1]["uv"][ids])]
    reg = register_meshes(prep, baselines=False, extra_correspondences=extra)
    pm = reg["meta"]["pairs"][0]
    assert pm["extra_correspondences"] == 60 and not pm["extra_rejected"]
    assert pm["static_correspondences"] == []  # extra correspondences replace `refine`
    assert pm["folded_triangles"]["dmt"] == 0 and pm["E_D"]["dmt"] < 1e-4

    def err(r):
        return np.sqrt(np.mean(np.sum((_placed_keys(r, "main")[1] - V1) ** 2, axis=1)))

    assert err(reg) < 0.75 * err(base)  # measured: 8.5e-3 against 1.35e-2
    with pytest.raises(ValueError, match="one \\(source, target\\) pair"):
        register_meshes(prep, baselines=False, extra_correspondences=extra * 2)
    with pytest.raises(ValueError, match="extra correspondences of pair 1"):
        register_meshes(
            prep, baselines=False, extra_correspondences=[(extra[0][0], extra[0][1][:5])]
        )


def test_to_first_disk_undoes_the_mobius_chain():
    from geometry.mobius_registration import MobiusTransform
    from pipelines.face_morph_pipeline import _to_first_disk

    z = np.array([[0.0, 0.0], [0.3, -0.2], [-0.5, 0.4]])
    M1 = MobiusTransform(0.2 + 0.1j, 0.7)
    M2 = MobiusTransform(-0.1 + 0.05j, -1.9)
    # key 2's disk = M2(M1(key 0's disk)); the inverses of pairs 1, 2 bring it back
    w, jac = _to_first_disk(M2.apply(M1.apply(z)), [M1.inverse(), M2.inverse()])
    np.testing.assert_allclose(w, z, atol=1e-12)
    # areas: |d(M2∘M1)/dz|² · jac = 1 (chain rule)
    np.testing.assert_allclose(
        jac * M2.jacobian_determinant(M1.apply(z)) * M1.jacobian_determinant(z), 1.0, rtol=1e-12
    )
    w0, jac0 = _to_first_disk(z, [])
    assert np.array_equal(w0, z) and np.all(jac0 == 1.0)


def test_key_disks_do_not_depend_on_how_each_input_disk_is_rotated():
    # a rotated disk map of one input (as a reordered copy can give) must not change
    # the key disk positions D(q, t_i) the homotopy interpolates
    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = face_mesh(1.0)
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    ref = register_meshes(prep, refine="none", baselines=False)
    c, s = np.cos(1.8), np.sin(1.8)
    Rz = np.array([[c, -s], [s, c]])
    rot = dict(prep[1])
    rot["uv"] = prep[1]["uv"] @ Rz.T
    rot["lm_uv"] = prep[1]["lm_uv"] @ Rz.T
    out = register_meshes([prep[0], rot], refine="none", baselines=False)
    np.testing.assert_allclose(out["key_uv__main"], ref["key_uv__main"], atol=1e-6)
    np.testing.assert_allclose(out["key_lam__main"], ref["key_lam__main"], rtol=1e-5)
    np.testing.assert_allclose(out["key_X__main"], ref["key_X__main"], atol=1e-6)


def test_api_offers_the_pipelines_curvature_homotopies_and_default():
    import typing

    from pipelines.face_morph_pipeline import CURVATURE_HOMOTOPIES, DEFAULT_CURVATURE
    from service.schemas import MorphCreate

    field = MorphCreate.model_fields["curvature"]
    assert field.default == DEFAULT_CURVATURE
    assert set(typing.get_args(field.annotation)) == set(CURVATURE_HOMOTOPIES)


def test_landmark_motion_is_affine_with_four_spatial_landmarks_else_constant():
    from pipelines.face_morph_pipeline import landmark_motion

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


def test_three_landmarks_morph_end_to_end(tmp_path):
    # m = 3 is the fewest landmarks the issue allows; both refinements must work with them
    paths, lms = [], []
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s)
        paths.append(write_obj(tmp_path / f"m{i}.obj", V, F))
        lms.append([lm[0], lm[1], lm[5]])  # the eyes and the chin
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    m = run_face_morph(paths, L, tmp_path / "o", frames=3, refine="nicp")
    (pair,) = m["registration"]["pairs"]
    # the refine="nicp" fit is Tikhonov-smoothed: landmarks met to ~1e-6, not exactly
    assert pair["folded_triangles"]["dmt"] == 0 and pair["E_D"]["dmt"] < 1e-4
    assert pair["nicp"]["correspondences"] > 0
    assert max(m["frames"]["key_frame_L2_to_inputs"]["dmt"]) < 0.02
    _validate([tmp_path / "o" / "animation.glb"])
    g = run_face_morph(paths, L, tmp_path / "g", frames=3, refine="guided", write_glb=False)
    (pair,) = g["registration"]["pairs"]
    assert pair["guide_polynomial_degree"] == 0  # constant plus r kernel with 3 landmarks
    assert pair["static_correspondences"][0] > 0
    assert pair["folded_triangles"]["dmt"] == 0 and pair["E_D"]["dmt"] < 1e-8


def test_normals_ride_on_the_morph_targets_when_asked(tmp_path):
    from pygltflib import GLTF2

    from geometry.vertex_normals import vertex_normals

    from .test_export_gltf import read_accessor

    paths, L = _inputs(tmp_path)
    out = tmp_path / "o"
    run_face_morph(paths, L, out, frames=3, normals=True, per_frame=True, key_metrics=False)
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
    _validate([out / "animation.glb", out / "frames" / "001.glb"])
    # the default stays position-only (FACTS.md: viewers guarantee 8 morphed attributes)
    run_face_morph(paths, L, tmp_path / "p", frames=3, key_metrics=False)
    prim = GLTF2().load(str(tmp_path / "p" / "animation.glb")).meshes[0].primitives[0]
    assert prim.attributes.NORMAL is None and prim.targets[0].get("NORMAL") is None


def _folded_face():
    """face_mesh(1.0) with one interior vertex pushed through its neighbours: its
    disk map folds before the fold repair (2 triangles with fold_policy="report")."""
    V, F, lm = face_mesh(1.0)
    i = int(np.argmin(np.hypot(V[:, 0] - 0.3, V[:, 1])))
    V[i, :2] += [0.35, 0.0]
    return V, F, lm


def test_prepare_mesh_refuses_a_disk_map_the_repair_leaves_folded(monkeypatch):
    import functools

    import geometry
    from geometry.mesh_errors import FoldedMapError

    V, F, lm = _folded_face()
    ok = prepare_mesh(V, F, lm, mesh_index=1)  # the repair unfolds it: accepted, reported
    assert ok["meta"]["disk_map"]["flipped"] == 0
    assert ok["meta"]["disk_map"]["flipped_before_repair"] > 0
    # the same real map without its repair stands for a fold the repair could not undo
    no_repair = functools.partial(geometry.disk_conformal_map, fold_policy="report")
    monkeypatch.setattr(geometry, "disk_conformal_map", no_repair)
    with pytest.raises(FoldedMapError, match="mesh 1: the disk map still has 2 folded"):
        prepare_mesh(V, F, lm, mesh_index=1)


def test_register_refuses_a_folded_composite_map():
    from geometry import disk_conformal_map
    from geometry.mesh_errors import FoldedMapError
    from pipelines.face_morph_pipeline import bijectivity_summary

    V0, F0, lm0 = face_mesh(0.0)
    V1, F1, lm1 = _folded_face()  # same faces as mesh 0
    prep = [prepare_mesh(V0, F0, lm0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    good = register_meshes(prep, method="identity", baselines=False)
    summary = bijectivity_summary([p["meta"] for p in prep], good["meta"])
    assert summary["folded_triangles"] == 0 and summary["min_jacobian"] > 0
    assert summary["disk_map_folded_before_repair"][1] > 0 and summary["fallbacks"] == []
    # a stage-1 result whose disk map folds (e.g. an edited stage file): the oracle
    # correspondence carries the fold into the composite map, which is refused
    folded = dict(prep[1])
    folded["uv"], info = disk_conformal_map(prep[1]["Vn"], F1, fold_policy="report")
    assert info.flipped == 2
    with pytest.raises(FoldedMapError, match="to key 1 \\(mesh 1\\) folds 2 of the"):
        register_meshes([prep[0], folded], method="identity", baselines=False)


def test_key_disk_positions_are_the_composite_images_not_snapped_to_chords():
    # a fine source rim against a coarse target rim: the target disk mesh covers only
    # the polygon of its 20·2 boundary chords, and the source's boundary nodes land on
    # the circle between them; their key disk positions must stay on the circle (snapping
    # them onto the chords collapses the chord–arc slivers and folds the rim)
    from geometry import boundary_loop, flipped_triangles

    V0, F0, lm0 = face_mesh(0.0, levels=4)
    V1, F1, lm1 = face_mesh(1.0, levels=1)
    prepared = [prepare_mesh(V0, F0, lm0, mesh_index=0), prepare_mesh(V1, F1, lm1, mesh_index=1)]
    reg = register_meshes(prepared, method="dmt", baselines=False)
    b = boundary_loop(reg["cm_F"])
    key = reg["key_uv__main"][1]
    np.testing.assert_allclose(np.hypot(*key[b].T), 1.0, atol=1e-9)
    assert not flipped_triangles(key, reg["cm_F"]).any()
    # the target's own rim is a coarse polygon: the sliver is real
    rim = prepared[1]["uv"][boundary_loop(prepared[1]["F"])]
    assert len(rim) < len(b) / 4
