import json

import numpy as np
import pytest

from .face_fixtures import face_mesh, write_obj
from .face_morph_inputs import (
    glb_texture,
    gradient_image,
    morph,
    textured_inputs,
    validate_glb,
    write_coloured_obj,
)


def test_textures_are_resampled_onto_one_atlas_and_cross_faded(tmp_path):
    from .test_export_gltf import read_accessor

    paths, L, imgs = textured_inputs(tmp_path)
    out = tmp_path / "o"
    m = morph(
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
    expect = [gradient_image(32, 40, 0.0), gradient_image(32, 40, 0.5)]
    expect.append(gradient_image(32, 40, 1.0))
    # texels inside mesh 0's UV disk (centre 0.5, radius 0.45); outside them, padding
    r, c = np.mgrid[0:32, 0:40]
    inside = np.hypot((c + 0.5) / 40 - 0.5, 1 - (r + 0.5) / 32 - 0.5) < 0.44
    # every key's texture on mesh 0's layout: mesh 1's mirrored picture comes back unmirrored
    from PIL import Image

    for i in (0, 1):
        key = np.asarray(Image.open(out / "textures" / f"key_{i:03d}.png"), dtype=float) / 255
        np.testing.assert_allclose(key[inside], expect[2 * i][inside], atol=1.5 / 255)
    # per-frame GLBs carry their own blend (t = 0.5: blue 0.5); the animation frame 0's
    g, t0 = glb_texture(out / "animation.glb")
    np.testing.assert_allclose(t0[inside], expect[0][inside], atol=1.5 / 255)
    prim = g.meshes[0].primitives[0]
    # the cross-fade rides on COLOR_0 targets; the default material is untextured (glTF
    # multiplies COLOR_0 into the texture), key 0's texture is the variant's material
    assert g.materials[prim.material].pbrMetallicRoughness.baseColorTexture is None
    mapping = prim.extensions["KHR_materials_variants"]["mappings"][0]
    assert g.materials[mapping["material"]].pbrMetallicRoughness.baseColorTexture is not None
    assert g.extensions["KHR_materials_variants"]["variants"] == [{"name": "key 0 texture"}]
    from conformorph.pipelines.mesh_io import read_mesh

    from .glb_playback import MorphGlb

    V0, _ = read_mesh(paths[0])
    uv0 = 0.5 + 0.45 * V0[:, :2]
    np.testing.assert_allclose(
        read_accessor(g, prim.attributes.TEXCOORD_0), np.c_[uv0[:, 0], 1 - uv0[:, 1]], atol=1e-6
    )
    # what three.js and Babylon show at the key times: the base colour plus the weighted
    # colour deltas (linear), encoded to sRGB as the screen shows it: the key's texture
    # at the vertex (R = u, G = v, B = 0 at key 0 and 1 at key 1)
    anim = MorphGlb.load(out / "animation.glb")
    C0 = read_accessor(g, prim.attributes.COLOR_0)
    dC = [read_accessor(g, t["COLOR_0"]) for t in prim.targets]
    for t_key, blue in ((0.0, 0.0), (1.0, 1.0)):
        w = anim.weights(t_key)
        lin = C0 + sum(wk * d for wk, d in zip(w, dC, strict=True))
        srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.abs(lin) ** (1 / 2.4) - 0.055)
        want = np.c_[uv0, np.full(len(uv0), blue)]
        assert np.abs(srgb - want).mean() <= 3 / 255, (t_key, np.abs(srgb - want).mean())
    for k in range(3):
        _, tk = glb_texture(out / "frames" / f"{k:03d}.glb")
        np.testing.assert_allclose(tk[inside], expect[k][inside], atol=1.5 / 255)
    validate_glb([out / "animation.glb", out / "frames" / "001.glb"])


def test_textures_through_dmt_with_other_connectivity_and_landmark_mesh(tmp_path):
    from PIL import Image

    paths, L, imgs = textured_inputs(tmp_path, reorder_last=True)
    out = tmp_path / "o"
    m = morph(paths, L, out, frames=2, textures=imgs, consistent="landmarks", key_metrics=False)
    assert m["registration"]["consistent_mesh"]["mode"] == "landmarks"
    k0, k1 = (
        np.asarray(Image.open(out / "textures" / f"key_{i:03d}.png"), dtype=float) / 255
        for i in (0, 1)
    )
    # the DMT correspondence is not the identity (the mouth moves), but close: R, G agree
    err = np.abs(k1[..., :2] - k0[..., :2])
    assert np.median(err) < 0.01 and err.max() < 0.1
    assert np.all(k1[..., 2] > 0.99) and np.all(k0[..., 2] < 0.01)
    validate_glb([out / "animation.glb"])
    # a mesh without texture coordinates cannot take a texture: a clear error
    V, F, lm = face_mesh(0.0)
    plain = write_obj(tmp_path / "plain.obj", V, F)
    with pytest.raises(ValueError, match="texture coordinate"):
        morph([plain, paths[1]], L, tmp_path / "o2", textures=imgs, write_glb=False)


def test_vertex_colours_from_the_files_are_resampled_and_cross_fade(tmp_path):
    from pygltflib import GLTF2

    from conformorph.pipelines.face_morph import read_vertex_colors

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
        paths.append(write_coloured_obj(tmp_path / f"c{i}.obj", V, F, C))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    C1 = read_vertex_colors(paths[1], 1937)
    assert C1 is not None and C1.shape == (1937, 3) and np.all(C1[:, 2] == 1.0)
    assert read_vertex_colors(write_obj(tmp_path / "plain.obj", *face_mesh(0.0)[:2]), 1937) is None
    out = tmp_path / "o"
    m = morph(paths, L, out, frames=3, per_frame=True, key_metrics=False)
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
    validate_glb([out / "animation.glb", out / "frames" / "001.glb"])
    # colours in only one input are not used (a cross-fade to nothing): said in the metrics
    plain = write_obj(tmp_path / "p1.obj", *face_mesh(1.0)[:2])
    L2 = tmp_path / "l2.json"
    L2.write_text(json.dumps({"landmarks": [lms[0], face_mesh(1.0)[2]]}))
    m = morph([paths[0], plain], L2, tmp_path / "o2", frames=2, key_metrics=False)
    app = m["registration"]["appearance"]
    assert app["source"] is None and app["inputs_with_vertex_colors"] == [True, False]
    assert "every input" in app["note"]
