"""Tests of conformorph.pipelines.export_gltf: morph-target GLB files, read back and run through the Khronos validator."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pygltflib as g
import pytest
from PIL import Image

from conformorph.geometry.vertex_normals import vertex_normals
from conformorph.pipelines.export_gltf import (
    MorphAppearance,
    MorphOutput,
    unit_vertex_normals,
    write_frame_glb,
    write_morph_glb,
)

ROOT = Path(__file__).resolve().parents[2]
VALIDATOR = ROOT / "tools" / "gltf_validate.mjs"

_DTYPES = {g.FLOAT: np.float32, g.UNSIGNED_INT: np.uint32, g.UNSIGNED_SHORT: np.uint16}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_accessor(gltf: g.GLTF2, index: int) -> np.ndarray:
    """Decode an accessor (dense or sparse) of a loaded GLB into an array."""
    blob = gltf.binary_blob()
    acc = gltf.accessors[index]
    w = _WIDTH[acc.type]

    def view(bv: int, offset: int, count: int, dtype: type, width: int) -> np.ndarray:
        v = gltf.bufferViews[bv]
        start = (v.byteOffset or 0) + (offset or 0)
        return np.frombuffer(blob, dtype=dtype, count=count * width, offset=start).reshape(
            count, width
        )

    if acc.bufferView is None:
        out = np.zeros((acc.count, w), dtype=_DTYPES[acc.componentType])
    else:
        out = view(acc.bufferView, acc.byteOffset, acc.count, _DTYPES[acc.componentType], w).copy()
    if acc.sparse is not None:
        s = acc.sparse
        idx = view(
            s.indices.bufferView, s.indices.byteOffset, s.count, _DTYPES[s.indices.componentType], 1
        )
        val = view(s.values.bufferView, s.values.byteOffset, s.count, _DTYPES[acc.componentType], w)
        out[idx[:, 0]] = val
    return out


def square_morph(T: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0]])
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    s = np.linspace(0, 1, T)
    frames = np.stack([V * [1 + k, 1, 1] + [0, 0, 0.1 * k] for k in s])
    frames[:, 4, 2] = 0.0  # the centre vertex never moves: sparse targets skip it
    return V, F, frames, np.linspace(0, 2.0, T)


def png_bytes() -> bytes:
    buf = io.BytesIO()
    Image.new("RGB", (8, 8), (10, 200, 30)).save(buf, "PNG")
    return buf.getvalue()


@pytest.mark.parametrize("sparse", [False, True])
def test_round_trip_positions_targets_and_weights(tmp_path, sparse):
    V, F, frames, times = square_morph()
    stats = write_morph_glb(tmp_path / "m.glb", V, F, frames, times, sparse=sparse)
    assert stats["targets"] == 5 and stats["bytes"] == (tmp_path / "m.glb").stat().st_size
    gl = g.GLTF2().load(str(tmp_path / "m.glb"))
    prim = gl.meshes[0].primitives[0]
    base = read_accessor(gl, prim.attributes.POSITION)
    assert np.allclose(base, V)
    assert gl.meshes[0].extras["targetNames"] == [f"frame_{k:03d}" for k in range(5)]
    assert gl.meshes[0].weights == [1.0, 0.0, 0.0, 0.0, 0.0]
    for k, tgt in enumerate(prim.targets):
        d = read_accessor(gl, tgt["POSITION"] if isinstance(tgt, dict) else tgt.POSITION)
        assert np.allclose(base + d, frames[k], atol=1e-6)
        acc = gl.accessors[tgt["POSITION"] if isinstance(tgt, dict) else tgt.POSITION]
        assert np.allclose(acc.min, d.min(0)) and np.allclose(acc.max, d.max(0))
        assert (acc.sparse is not None) == sparse
    assert np.array_equal(read_accessor(gl, prim.indices).reshape(-1, 3), F)
    anim = gl.animations[0]
    (ch,) = anim.channels
    assert ch.target.path == "weights" and ch.target.node == 0
    smp = anim.samplers[ch.sampler]
    assert smp.interpolation == "LINEAR"
    tin = read_accessor(gl, smp.input)[:, 0]
    assert np.allclose(tin, times)
    acc_in = gl.accessors[smp.input]
    assert acc_in.min == [pytest.approx(0.0)] and acc_in.max == [pytest.approx(2.0)]
    W = read_accessor(gl, smp.output).reshape(5, 5)
    assert np.array_equal(W, np.eye(5))
    # at any time, LINEAR interpolation of one-hot keys leaves ≤ 2 non-zero weights summing to 1
    for t in np.linspace(0, 2, 37):
        w = np.array([np.interp(t, tin, W[:, j]) for j in range(5)])
        assert np.count_nonzero(w > 1e-12) <= 2 and w.sum() == pytest.approx(1.0)


def test_sparse_is_smaller_when_few_vertices_move(tmp_path):
    V = np.c_[np.random.default_rng(0).random((400, 2)), np.zeros(400)]
    F = np.array([[i, i + 1, i + 2] for i in range(0, 396, 3)])
    frames = np.repeat(V[None], 6, axis=0)
    frames[:, :10, 2] = np.linspace(0, 1, 6)[:, None]
    dense = write_morph_glb(tmp_path / "d.glb", V, F, frames, np.arange(6.0))
    sp = write_morph_glb(tmp_path / "s.glb", V, F, frames, np.arange(6.0), sparse=True)
    assert sp["bytes"] < 0.5 * dense["bytes"]


def test_rigid_channels_and_texture(tmp_path):
    V, F, frames, times = square_morph(3)
    ang = np.array([0.0, 0.4, 0.8])
    rot = np.c_[np.zeros((3, 2)), np.sin(ang / 2), np.cos(ang / 2)]
    tr = np.c_[np.arange(3.0), np.zeros((3, 2))]
    write_morph_glb(
        tmp_path / "r.glb",
        V,
        F,
        frames,
        times,
        rigid=(tr, rot, np.ones((3, 3))),
        appearance=MorphAppearance(normals=True, uv=V[:, :2], texture_png=png_bytes()),
    )
    gl = g.GLTF2().load(str(tmp_path / "r.glb"))
    paths = sorted(c.target.path for c in gl.animations[0].channels)
    assert paths == ["rotation", "scale", "translation", "weights"]
    ch = next(c for c in gl.animations[0].channels if c.target.path == "rotation")
    assert np.allclose(
        read_accessor(gl, gl.animations[0].samplers[ch.sampler].output), rot, atol=1e-7
    )
    assert gl.images[0].mimeType == "image/png"
    assert gl.materials[0].pbrMetallicRoughness.baseColorTexture.index == 0
    # the rest transform is frame 0's, whose identity parts are left out of the node
    assert gl.nodes[0].rotation is None and gl.nodes[0].scale is None
    assert gl.nodes[0].translation is None


def test_rest_transform_of_frame_0_and_no_scale_channel_without_scale(tmp_path):
    V, F, frames, times = square_morph(3)
    ang = np.array([0.3, 0.4, 0.8])
    rot = np.c_[np.zeros((3, 2)), np.sin(ang / 2), np.cos(ang / 2)]
    tr = np.c_[np.arange(1.0, 4.0), np.zeros((3, 2))]
    write_morph_glb(tmp_path / "r.glb", V, F, frames, times, rigid=(tr, rot))
    gl = g.GLTF2().load(str(tmp_path / "r.glb"))
    assert sorted(c.target.path for c in gl.animations[0].channels) == [
        "rotation",
        "translation",
        "weights",
    ]
    assert gl.nodes[0].rotation == pytest.approx(list(rot[0]))
    assert gl.nodes[0].translation == pytest.approx([1.0, 0.0, 0.0])
    assert gl.nodes[0].scale is None


def test_frame_glb_2d_positions_at_z0(tmp_path):
    V = np.array([[0.0, 0], [2, 0], [0, 1]])
    stats = write_frame_glb(tmp_path / "f.glb", V, [[0, 1, 2]], normals=True)
    assert stats == {"bytes": stats["bytes"], "vertices": 3, "faces": 1, "targets": 0}
    gl = g.GLTF2().load(str(tmp_path / "f.glb"))
    P = read_accessor(gl, gl.meshes[0].primitives[0].attributes.POSITION)
    assert np.allclose(P, np.c_[V, np.zeros(3)])
    N = read_accessor(gl, gl.meshes[0].primitives[0].attributes.NORMAL)
    assert np.allclose(N, [0, 0, 1])


def _normals_and_targets(path: Path) -> tuple[np.ndarray, list]:
    gl = g.GLTF2().load(str(path))
    prim = gl.meshes[0].primitives[0]
    assert prim.attributes.NORMAL is not None
    return read_accessor(gl, prim.attributes.NORMAL).astype(np.float64), prim.targets


def test_base_normals_always_normal_targets_by_default_where_normals_change(tmp_path):
    V, F, frames, times = square_morph(3)
    planar = V * np.array([1.0, 1.0, 0.0]) * np.linspace(1, 2, 3)[:, None, None]
    flat = write_morph_glb(tmp_path / "flat.glb", V, F, planar, times)  # normals stay +z
    assert flat["normal_targets"] is False
    assert all("NORMAL" not in t for t in _normals_and_targets(tmp_path / "flat.glb")[1])
    V[4, 2] = 0.3  # a tent: every vertex has its own smooth normal
    frames[:, 4, 2] = 0.3
    for sparse in (False, True):
        off = MorphAppearance(normals=False)
        write_morph_glb(tmp_path / "m.glb", V, F, frames, times, sparse=sparse, appearance=off)
        N, targets = _normals_and_targets(tmp_path / "m.glb")
        np.testing.assert_allclose(np.linalg.norm(N, axis=1), 1.0, atol=1e-6)
        np.testing.assert_allclose(N, vertex_normals(V, F), atol=1e-6)
        assert len(np.unique(N.round(6), axis=0)) == 5  # smooth, not one normal per face
        assert all("NORMAL" not in t or t["NORMAL"] is None for t in targets)
    info = write_morph_glb(tmp_path / "n.glb", V, F, frames, times)  # the default
    assert info["normal_targets"] is True
    gl = g.GLTF2().load(str(tmp_path / "n.glb"))
    prim = gl.meshes[0].primitives[0]
    N0 = read_accessor(gl, prim.attributes.NORMAL).astype(np.float64)
    np.testing.assert_allclose(N0, vertex_normals(V, F), atol=1e-6)
    for k, tgt in enumerate(prim.targets):
        dN = read_accessor(gl, tgt["NORMAL"])
        np.testing.assert_allclose(N0 + dN, vertex_normals(frames[k], F), atol=1e-6)
    write_frame_glb(tmp_path / "f.glb", frames[2], F)
    N, _ = _normals_and_targets(tmp_path / "f.glb")
    np.testing.assert_allclose(N, vertex_normals(frames[2], F), atol=1e-6)
    write_frame_glb(tmp_path / "plain.glb", frames[2], F, normals=False)
    gl = g.GLTF2().load(str(tmp_path / "plain.glb"))
    assert gl.meshes[0].primitives[0].attributes.NORMAL is None


def test_unit_vertex_normals_never_zero():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]])  # vertex 3 is in no face
    F = np.array([[0, 1, 2]])
    N = unit_vertex_normals(V, F)
    np.testing.assert_allclose(N, [[0, 0, 1]] * 4)
    V[2] = [0.0, 0.0, 1.0]  # x-z plane, face normal -y; the lone vertex still +z
    N = unit_vertex_normals(V, F)
    np.testing.assert_allclose(N[:3], [[0, -1, 0]] * 3)
    np.testing.assert_allclose(N[3], [0, 0, 1])
    np.testing.assert_allclose(N[:3], vertex_normals(V, F)[:3])


def test_validation_errors(tmp_path):
    V, F, frames, times = square_morph(3)
    p = tmp_path / "x.glb"
    with pytest.raises(ValueError, match="strictly increasing"):
        write_morph_glb(p, V, F, frames, [0.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="frames_V"):
        write_morph_glb(p, V, F, frames[:, :3], times[:3])
    with pytest.raises(ValueError, match="face indices"):
        write_morph_glb(p, V, F + 10, frames, times)
    with pytest.raises(ValueError, match="unit length"):
        write_morph_glb(
            p, V, F, frames, times, rigid=(np.zeros((3, 3)), np.ones((3, 4)), np.ones((3, 3)))
        )
    with pytest.raises(ValueError, match="colors"):
        write_morph_glb(
            p, V, F, frames, times, appearance=MorphAppearance(colors=np.full((5, 3), 2.0))
        )
    with pytest.raises(ValueError, match="PNG"):
        write_frame_glb(p, V, F, uv=V[:, :2], texture_png=b"GIF89a")
    with pytest.raises(ValueError, match="needs uv"):
        write_frame_glb(p, V, F, texture_png=png_bytes())
    assert not p.exists()


def test_inputs_not_mutated(tmp_path):
    V, F, frames, times = square_morph(3)
    c = V.copy(), F.copy(), frames.copy(), times.copy()
    write_morph_glb(
        tmp_path / "m.glb",
        V,
        F,
        frames,
        times,
        sparse=True,
        appearance=MorphAppearance(normals=True),
    )
    for a, b in zip((V, F, frames, times), c, strict=True):
        assert np.array_equal(a, b)


def test_khronos_validator_reports_no_errors_or_warnings(tmp_path):
    node = shutil.which("node")
    if node is None:
        pytest.skip(
            "node is not installed: cannot run the Khronos glTF validator (npm gltf-validator)"
        )
    if not (ROOT / "node_modules" / "gltf-validator").is_dir():
        pytest.fail("npm package gltf-validator missing: run `npm ci` at the repository root")
    V, F, frames, times = square_morph(4)
    ang = np.linspace(0, 1, 4)
    rot = np.c_[np.zeros((4, 2)), np.sin(ang / 2), np.cos(ang / 2)]
    cols = np.random.default_rng(1).random((4, 5, 4))
    files = []
    variants = {
        "plain": {},
        "sparse_normals": {"sparse": True, "appearance": MorphAppearance(normals=True)},
        "everything": {
            "appearance": MorphAppearance(
                normals=True, colors=cols, uv=V[:, :2], texture_png=png_bytes()
            ),
            "rigid": (np.zeros((4, 3)), rot, np.ones((4, 3))),
        },
        "sparse_colors": {"sparse": True, "appearance": MorphAppearance(colors=cols)},
        "static_colors": {"appearance": MorphAppearance(colors=cols[0, :, :3])},
        "meshopt": {
            "appearance": MorphAppearance(colors=cols, uv=V[:, :2], texture_png=png_bytes()),
            "rigid": (np.zeros((4, 3)), rot),
            "output": MorphOutput(compress="meshopt"),
        },
    }
    for name, kw in variants.items():
        write_morph_glb(tmp_path / f"{name}.glb", V, F, frames, times, **kw)
        files.append(tmp_path / f"{name}.glb")
    write_morph_glb(tmp_path / "one_frame.glb", V, F, frames[:1], times[:1])
    lone = np.r_[V, [[3.0, 3.0, 3.0]]]  # a vertex no face uses: its NORMAL is still unit
    write_frame_glb(tmp_path / "lone.glb", lone, F)
    files.append(tmp_path / "lone.glb")
    write_frame_glb(
        tmp_path / "frame.glb", V, F, normals=True, uv=V[:, :2], texture_png=png_bytes()
    )
    write_frame_glb(tmp_path / "frame_meshopt.glb", V, F, uv=V[:, :2], compress="meshopt")
    files += [tmp_path / "one_frame.glb", tmp_path / "frame.glb", tmp_path / "frame_meshopt.glb"]
    proc = subprocess.run(
        [node, str(VALIDATOR), *map(str, files)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    reports = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert len(reports) == len(files), proc.stderr
    for r in reports:
        assert (r["errors"], r["warnings"]) == (0, 0), r
    assert proc.returncode == 0


def test_meshopt_compression_round_trip_within_its_tolerance(tmp_path):
    from conformorph.pipelines.gltf_compression import (
        AUTO_MIN_BYTES,
        NORMAL_TOLERANCE,
        mantissa_bits,
    )
    from conformorph.pipelines.gltf_quantization import POSITION_ERROR
    from tests.pipelines.glb_playback import MorphGlb

    rng = np.random.default_rng(3)
    n, T = 400, 6
    V = np.c_[rng.random((n, 2)), np.zeros(n)] + [0.0, 1.6, 0.1]  # off the origin
    from scipy.spatial import Delaunay

    F = Delaunay(V[:, :2]).simplices.astype(np.int64)
    frames = np.stack([V + [0, 0, 0.05 * k] * np.sin(3 * V[:, :1]) for k in range(T)])
    times = np.arange(T) / 10.0
    plain = write_morph_glb(tmp_path / "p.glb", V, F, frames, times)
    small = write_morph_glb(
        tmp_path / "a.glb", V, F, frames, times, output=MorphOutput(compress="auto")
    )
    assert small["bytes"] == plain["bytes"] < AUTO_MIN_BYTES  # auto: small files stay plain
    packed = write_morph_glb(
        tmp_path / "m.glb", V, F, frames, times, output=MorphOutput(compress="meshopt")
    )
    assert packed["bytes"] < plain["bytes"] / 2
    gl = g.GLTF2().load(str(tmp_path / "m.glb"))
    assert gl.extensionsRequired == ["KHR_mesh_quantization", "EXT_meshopt_compression"]
    assert gl.buffers[1].extensions["EXT_meshopt_compression"]["fallback"] is True
    a, b = MorphGlb.load(tmp_path / "p.glb"), MorphGlb.load(tmp_path / "m.glb")

    def rotated(F: np.ndarray) -> np.ndarray:  # each triangle from its smallest index
        r = np.argmin(F, axis=1)
        return np.stack([np.roll(f, -k) for f, k in zip(F, r, strict=True)])

    # indices: lossless up to a rotation of each triangle (the winding kept) and the
    # triangles' order (vertex-cache order); vertex i stays vertex i
    np.testing.assert_array_equal(np.unique(rotated(a.F), axis=0), np.unique(rotated(b.F), axis=0))
    assert len(b.F) == len(a.F)
    diag = float(np.linalg.norm(np.ptp(V, axis=0)))
    bound = packed["quantization"]["position_error_bound"]
    assert bound <= POSITION_ERROR * diag
    for t in np.linspace(0, times[-1], 11):
        err = np.linalg.norm(a.positions(t) - b.positions(t), axis=1).max()
        assert err <= bound, (t, err / diag)  # base + the two active deltas
        assert np.abs(a.shader_normals(t) - b.shader_normals(t)).max() < 4 * NORMAL_TOLERANCE
    assert mantissa_bits(np.array([[1.0, 0.5, 0.0]], np.float32), 2**-10) == 11
    assert mantissa_bits(np.zeros((2, 3), np.float32), 1e-3) == 8
    assert mantissa_bits(np.array([[1e9, 0, 0]], np.float32), 1e-9) == 24
    with pytest.raises(ValueError, match="compress must be one of"):
        write_morph_glb(tmp_path / "x.glb", V, F, frames, times, output=MorphOutput(compress="zip"))


@pytest.mark.parametrize("colors", [False, True])
def test_auto_compression_judges_the_float_file_from_its_arrays(tmp_path, colors):
    """``--compress auto`` decides from the float file's size without building it: the
    estimate is its binary buffer, so the file exceeds it only by its JSON, the weights
    animation and padding (a few KB here)."""
    from scipy.spatial import Delaunay

    from conformorph.pipelines.export_gltf import (
        MorphAppearance,
        TargetData,
        _float_buffer_bytes,
        _MorphDocument,
    )
    from conformorph.pipelines.glb_normals import unit_vertex_normals as unit_normals

    rng = np.random.default_rng(5)
    n, T = 300, 5
    V = np.c_[rng.random((n, 2)), np.zeros(n)]
    F = Delaunay(V[:, :2]).simplices.astype(np.int64)
    frames = np.stack([V + [0, 0, 0.1 * k] * np.sin(4 * V[:, :1]) for k in range(T)])
    C = rng.random((T, n, 3)) if colors else None
    app = MorphAppearance(colors=C)
    out = write_morph_glb(tmp_path / "f.glb", V, F, frames, np.arange(T) / 4, appearance=app)
    frame_N = np.stack([unit_normals(f, F) for f in frames])
    data = TargetData(frames, V, frame_N, frame_N[0], C, None if C is None else C[0])
    doc = _MorphDocument(F.astype(np.uint32), np.arange(T) / 4, [], app, None, False, "m", {})
    estimate = _float_buffer_bytes(doc, data)
    assert out["normal_targets"]
    assert 0 < out["bytes"] - estimate < 8192, (out["bytes"], estimate)
