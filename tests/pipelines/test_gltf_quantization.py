"""Compressed morph GLBs (issue 29, compact files): KHR_mesh_quantization targets under
EXT_meshopt_compression, decoded (Python's meshopt binding, three.js' MeshoptDecoder) and
compared frame by frame with the float file; the Khronos validator on every variant."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pygltflib as g
import pytest

from conformorph.pipelines.export_gltf import MorphAppearance, MorphOutput, write_morph_glb
from conformorph.pipelines.gltf_compression import (
    AUTO_MIN_BYTES,
    COLOR_TOLERANCE,
    cache_ordered_triangles,
    compresses,
)
from conformorph.pipelines.gltf_quantization import (
    POSITION_ERROR,
    SHORT_MAX,
    central_frame,
    normal_delta_rows,
    position_grid,
    snorm16_rows,
    unorm16_rows,
)

from .face_morph_inputs import ROOT, validate_glb
from .glb_playback import MorphGlb, read_accessor, three_playback


def bending_sheet(T: int = 7, n: int = 24) -> tuple[np.ndarray, ...]:
    """A grid sheet bent into a half cylinder over T frames (normals turn up to 90°),
    off the origin, with per-frame colours and a rigid turn about z."""
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    u, v = u.ravel(), v.ravel()
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j
            F += [[a, a + 1, a + n], [a + 1, a + n + 1, a + n]]
    frames = []
    for k in range(T):
        bend = 0.5 * np.pi * k / (T - 1) + 1e-9
        r = 1.0 / bend
        x, z = r * np.sin(bend * u), r * (1 - np.cos(bend * u))
        frames.append(np.c_[x, v, z] * 0.2 + [3.0, -1.0, 0.5])
    fr = np.stack(frames)
    cols = np.stack([np.c_[u, v, np.full_like(u, k / (T - 1))] for k in range(T)])
    ang = np.linspace(0, 0.4, T)
    rot = np.c_[np.zeros((T, 2)), np.sin(ang / 2), np.cos(ang / 2)]
    return fr[0], np.asarray(F), fr, np.linspace(0, 1.5, T), cols, rot


def test_position_grid_by_hand():
    # a 3 x 4 x 0 box: diagonal 5; budget 1e-4 · 5 / √3, 1/8 to the base, the rest to s/2
    V = np.array([[0.0, 0, 0], [3, 0, 0], [3, 4, 0], [0, 4, 0]])
    frames = np.stack([V, V + [0.0, 0.0, 1e-3]])
    grid = position_grid(V, frames)
    budget = POSITION_ERROR * 5.0 / np.sqrt(3)
    assert grid.base_tolerance == pytest.approx(budget / 8)
    assert grid.step == pytest.approx(2 * budget * 7 / 8)
    assert grid.scale == pytest.approx(grid.step * SHORT_MAX)
    np.testing.assert_allclose(grid.offset, [1.5, 2.0, 0.0])
    assert grid.error_bound == pytest.approx(POSITION_ERROR * 5.0)
    # a delta longer than 32767 steps: the step grows to reach it
    far = np.stack([V, V + [0.0, 0.0, 40.0]])
    assert position_grid(V, far).scale == pytest.approx(40.0)


def test_central_frame_by_hand():
    V = np.zeros((2, 3))
    frames = np.stack([V + [0.0, 0, z] for z in (0.0, 1.0, 2.0, 10.0)])  # mean z = 3.25
    assert central_frame(frames) == 2
    assert central_frame(frames[:1]) == 0


def test_integer_rows_by_hand():
    rows = snorm16_rows(np.array([[0.5, -1.0, 0.25]]), 2.0)
    np.testing.assert_array_equal(rows, [[8192, -16384, 4096, 0]])  # 32767/4 = 8191.75
    assert rows.dtype == np.int16
    np.testing.assert_array_equal(unorm16_rows(np.array([[0.0, 1.0, 0.5]])), [[0, 65535, 32768, 0]])
    # a 37° turn fits as it is: λ = 1, rows = (N_k − N_base) · 127
    r = normal_delta_rows(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.6, 0.8]]))
    np.testing.assert_array_equal(r, [[0, 76, -25, 0]])
    # a 127° turn does not: λ = 0.25, the largest with λ·n_z − b_z ≥ −1; base + delta is
    # (0, 0.15, −0.2), frame k's direction
    b, n = np.array([[0.6, 0.0, 0.8]]), np.array([[0.0, 0.6, -0.8]])
    r = normal_delta_rows(b, n)
    np.testing.assert_array_equal(r, [[-76, 19, -127, 0]])
    shown = b + r[:, :3] / 127.0
    cos = float(shown[0] @ n[0] / np.linalg.norm(shown))
    assert np.degrees(np.arccos(min(cos, 1.0))) < 1.0


def test_compress_choice_and_cache_order():
    assert compresses("meshopt", 10) and not compresses("none", AUTO_MIN_BYTES * 4)
    assert compresses("auto", AUTO_MIN_BYTES + 1) and not compresses("auto", AUTO_MIN_BYTES)
    _, F, *_ = bending_sheet()
    tri = cache_ordered_triangles(F.reshape(-1).astype(np.uint32)).reshape(-1, 3)
    key = np.sort(tri, axis=1)
    assert len(np.unique(key, axis=0)) == len(F)
    np.testing.assert_array_equal(np.unique(key, axis=0), np.unique(np.sort(F, axis=1), axis=0))
    # each triangle keeps its winding: a cyclic rotation of an input triangle
    cyc = {tuple(np.roll(f, -int(np.argmin(f)))) for f in F}
    assert {tuple(np.roll(f, -int(np.argmin(f)))) for f in tri} == cyc


@pytest.fixture(scope="module")
def sheet_files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("quant")
    V, F, frames, times, cols, rot = bending_sheet()
    kw = {
        "appearance": MorphAppearance(normals=True, colors=cols),
        "rigid": (np.zeros((len(times), 3)), rot),
    }
    plain = write_morph_glb(tmp / "plain.glb", V, F, frames, times, **kw)
    packed = write_morph_glb(
        tmp / "packed.glb", V, F, frames, times, output=MorphOutput(compress="meshopt"), **kw
    )
    return tmp, plain, packed, (V, F, frames, times, cols)


def test_compressed_targets_are_quantized_under_a_dequantization_child(sheet_files):
    tmp, plain, packed, _ = sheet_files
    assert plain["quantization"] is None and packed["normal_targets"]
    gl = g.GLTF2().load(str(tmp / "packed.glb"))
    assert gl.extensionsRequired == ["KHR_mesh_quantization", "EXT_meshopt_compression"]
    top, child = gl.nodes
    assert top.mesh is None and top.children == [1] and top.name == "morph"
    assert (top.translation, top.rotation, top.scale, top.matrix) == (None, None, None, None)
    assert child.mesh == 0 and child.rotation is None
    assert child.scale == [pytest.approx(packed["quantization"]["position_step"] * SHORT_MAX)] * 3
    paths = {(c.target.node, c.target.path) for c in gl.animations[0].channels}
    assert paths == {(1, "weights"), (0, "translation"), (0, "rotation")}
    prim = gl.meshes[0].primitives[0]
    acc = gl.accessors
    assert acc[prim.attributes.POSITION].componentType == g.FLOAT
    assert (acc[prim.attributes.NORMAL].componentType, acc[prim.attributes.NORMAL].normalized) == (
        g.SHORT,
        True,
    )
    assert acc[prim.attributes.COLOR_0].componentType == g.UNSIGNED_SHORT
    for tgt in prim.targets:
        assert (acc[tgt["POSITION"]].componentType, acc[tgt["POSITION"]].normalized) == (
            g.SHORT,
            True,
        )
        assert acc[tgt["NORMAL"]].componentType == g.BYTE
        assert acc[tgt["COLOR_0"]].componentType == g.SHORT
    filters = {
        bv.extensions["EXT_meshopt_compression"].get("filter")
        for bv in gl.bufferViews
        if bv.extensions
    }
    assert {"OCTAHEDRAL", "EXPONENTIAL", None} <= filters
    assert packed["bytes"] < plain["bytes"] / 3
    # the base is the central frame (shorter targets); the weights at rest pick frame 0
    _, _, _, (V, F, frames, times, cols) = sheet_files
    b = MorphGlb.load(tmp / "packed.glb")
    Rc, tc, sc = b.child_transform()
    k = central_frame(frames)
    assert k == len(frames) // 2
    np.testing.assert_allclose(
        b.base_V * sc + tc, frames[k], atol=packed["quantization"]["position_step"]
    )
    assert gl.meshes[0].weights == [1.0] + [0.0] * (len(frames) - 1)


def test_every_frame_decodes_within_the_stated_tolerance(sheet_files):
    """Decoded with meshoptimizer (Python binding), frames and midpoints, against the
    float file: positions within the bound (≤ 1e-4 of the diagonal), normals and colours."""
    tmp, _, packed, (V, F, frames, times, cols) = sheet_files
    a, b = MorphGlb.load(tmp / "plain.glb"), MorphGlb.load(tmp / "packed.glb")
    bound = packed["quantization"]["position_error_bound"]
    diag = min(float(np.linalg.norm(np.ptp(f, axis=0))) for f in frames)
    assert bound <= POSITION_ERROR * diag * (1 + 1e-12)
    mid = (times[1:] + times[:-1]) / 2
    worst = 0.0
    for t in np.r_[times, mid]:
        err = np.linalg.norm(b.positions(t) - a.positions(t), axis=1).max()
        worst = max(worst, err)
        assert err <= bound, (t, err / diag)
        cos = np.clip(np.sum(a.shader_normals(t) * b.shader_normals(t), axis=1), -1, 1)
        assert np.degrees(np.arccos(cos)).max() < 1.0  # turns ≤ 90°: λ ≥ 0.5 here
    assert worst > 0.0  # quantized, not float
    gl = b.gl
    prim = gl.meshes[0].primitives[0]
    base_c = read_accessor(gl, prim.attributes.COLOR_0)
    for k, tgt in enumerate(prim.targets):
        got = base_c + read_accessor(gl, tgt["COLOR_0"])
        assert np.abs(got - cols[k]).max() <= COLOR_TOLERANCE


def test_validator_clean_on_every_compressed_variant(sheet_files, tmp_path):
    tmp, *_ = sheet_files
    V, F, frames, times, cols, rot = bending_sheet()
    out = MorphOutput(compress="meshopt")
    write_morph_glb(tmp_path / "positions.glb", V, F, frames, times, output=out)
    write_morph_glb(
        tmp_path / "normals.glb", V, F, frames, times, appearance=MorphAppearance(), output=out
    )
    write_morph_glb(
        tmp_path / "rgba_uv.glb",
        V,
        F,
        frames,
        times,
        appearance=MorphAppearance(
            colors=np.concatenate([cols, cols[..., :1]], axis=2), uv=V[:, :2]
        ),
        rigid=(np.zeros((len(times), 3)), rot, np.ones((len(times), 3))),
        output=out,
    )
    write_morph_glb(tmp_path / "one.glb", V, F, frames[:1], times[:1], output=out)
    files = [tmp / "packed.glb", tmp / "plain.glb", *sorted(tmp_path.glob("*.glb"))]
    validate_glb(files)


def test_three_js_plays_the_compressed_file_like_the_float_one(sheet_files):
    """three.js r187 (GLTFLoader + MeshoptDecoder in Node): node 0's rest transform the
    identity, every frame within the bound of the float file."""
    tmp, _, packed, (V, F, frames, times, cols) = sheet_files
    # increasing: a LoopOnce action that reached its end stays there
    ts = sorted(float(t) for t in np.r_[times, (times[1:] + times[:-1]) / 2])
    got = three_playback(tmp / "packed.glb", ts)
    assert got["rest"] == {  # the top-level node's (the mesh is on a dequantization child)
        "position": [0, 0, 0],
        "quaternion": [0, 0, 0, 1],
        "scale": [1, 1, 1],
    }
    a = MorphGlb.load(tmp / "plain.glb")
    bound = packed["quantization"]["position_error_bound"]
    for frame in got["frames"]:
        P = np.asarray(frame["positions"])
        err = np.linalg.norm(P - a.positions(frame["t"]), axis=1).max()
        assert err <= bound * (1 + 1e-4) + 1e-7, (frame["t"], err)
        cos = np.clip(
            np.sum(np.asarray(frame["normals"]) * a.shader_normals(frame["t"]), axis=1), -1, 1
        )
        assert np.percentile(np.degrees(np.arccos(cos)), 95) < 1.0


_VIEWER_READ = """
import { readFile } from "node:fs/promises";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { MeshoptDecoder } from "three/addons/libs/meshopt_decoder.module.js";
const { floatValues } = await import(process.argv[2]);
const bytes = await readFile(process.argv[1]);
const buf = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
const loader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder);
const gltf = await new Promise((res, rej) => loader.parse(buf, "", res, rej));
let mesh = null;
gltf.scene.traverse((o) => { if (!mesh && o.isMesh) mesh = o; });
const g = mesh.geometry;
console.log(JSON.stringify({
  base: Array.from(floatValues(g.attributes.position)),
  targets: g.morphAttributes.position.map((t) => Array.from(floatValues(t))),
  quantized: g.morphAttributes.position.map((t) => t.normalized),
}));
"""


def test_viewer_reads_quantized_targets_as_floats(sheet_files):
    """viewer/src/attributes.js (the viewer's reading of positions and targets for its
    boxes and histogram) in Node on three.js' decoding of the compressed file."""
    node = shutil.which("node")
    if node is None or not (ROOT / "node_modules" / "three").is_dir():
        pytest.skip("node / npm three not installed")
    tmp, *_ = sheet_files
    module = (ROOT / "viewer" / "src" / "attributes.js").as_uri()
    proc = subprocess.run(
        [node, "--input-type=module", "-e", _VIEWER_READ, str(tmp / "packed.glb"), module],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout)
    assert all(got["quantized"])
    b = MorphGlb.load(tmp / "packed.glb")
    np.testing.assert_allclose(np.reshape(got["base"], (-1, 3)), b.base_V, atol=1e-7)
    for k, d in enumerate(got["targets"]):
        np.testing.assert_allclose(np.reshape(d, (-1, 3)), b.dV[k], atol=1e-7)
