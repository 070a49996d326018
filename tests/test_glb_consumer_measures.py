"""The measurements of benchmarks/bench_glb_consumers.py on hand-worked cases: a frame
placed by its node chain, texture sampling at glTF coordinates, the sRGB curve, the rest
transform check, and the key-frame and lighting figures of a consumer row."""

from __future__ import annotations

import numpy as np
import pygltflib as g

from benchmarks import glb_consumer_measures as gm
from benchmarks.glb_consumer_report import targets_failed


def _two_node_glb(path, P):
    """node 0 (translation [1, 2, 3], 90° about z) with child node 1 (scale 2) holding P."""
    blob = P.astype(np.float32).tobytes()
    gl = g.GLTF2(
        scene=0,
        scenes=[g.Scene(nodes=[0])],
        nodes=[
            g.Node(children=[1], translation=[1, 2, 3], rotation=[0, 0, 2**-0.5, 2**-0.5]),
            g.Node(mesh=0, scale=[2, 2, 2]),
        ],
        meshes=[g.Mesh(primitives=[g.Primitive(attributes=g.Attributes(POSITION=0))])],
        accessors=[
            g.Accessor(
                bufferView=0,
                componentType=g.FLOAT,
                count=len(P),
                type=g.VEC3,
                min=P.min(0).tolist(),
                max=P.max(0).tolist(),
            )
        ],
        bufferViews=[g.BufferView(buffer=0, byteLength=len(blob))],
        buffers=[g.Buffer(byteLength=len(blob))],
    )
    gl.set_binary_blob(blob)
    gl.save_binary(str(path))


def test_frame_positions_follow_the_node_chain(tmp_path):
    P = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    _two_node_glb(tmp_path / "f.glb", P)
    # (1, 0, 0) -> scale 2 -> (2, 0, 0) -> 90° about z -> (0, 2, 0) -> + (1, 2, 3)
    want = np.array([[1.0, 4.0, 3.0], [1.0, 2.0, 5.0]])
    np.testing.assert_allclose(gm.frame_positions(tmp_path / "f.glb"), want, atol=1e-6)


def test_texture_sampling_and_srgb_by_hand():
    img = np.zeros((2, 2, 3))
    img[0, 0] = [1.0, 0.0, 0.0]  # glTF v = 0 is the image's top row
    img[1, 1] = [0.0, 0.0, 1.0]
    uv = np.array([[0.25, 0.25], [0.75, 0.75], [0.5, 0.25]])
    got = gm.texture_at(img, uv)
    np.testing.assert_allclose(got[0], [1, 0, 0])
    np.testing.assert_allclose(got[1], [0, 0, 1])
    np.testing.assert_allclose(got[2], [0.5, 0, 0])  # halfway along the top row
    np.testing.assert_allclose(
        gm.srgb(np.array([0.0, 0.0031308, 0.5, 1.0])),
        [0.0, 0.040449936, 0.735356983, 1.0],
        atol=1e-8,
    )


def test_rest_identity_allows_the_negated_quaternion_only():
    rest = {"position": [0, 0, 0], "quaternion": [0, 0, -0.0, -1], "scale": [1, 1, 1]}
    assert gm.rest_is_identity(rest)
    assert not gm.rest_is_identity({**rest, "position": [0, 1e-6, 0]})
    assert not gm.rest_is_identity({**rest, "scale": [1, 1, 20.48]})
    assert not gm.rest_is_identity(None)


def _reference():
    # a 0.2 m square in z = 0, two frames: the second lifts vertex 3 by 0.2 m
    V = 0.2 * np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    P1 = V.copy()
    P1[3, 2] = 0.2
    F = np.array([[0, 1, 3], [0, 3, 2]])
    return gm.Reference(np.array([0.0, 1.0]), np.stack([V, P1]), F, [0, 1], {}, [])


def test_geometry_row_key_deviation_and_corner_normals():
    ref = _reference()
    ident = {"position": [0, 0, 0], "quaternion": [0, 0, 0, 1], "scale": [1, 1, 1]}
    shifted = ref.positions.copy()
    shifted[1, 0, 0] += 2e-6 * ref.diagonal
    true = np.stack([ref.true_normals(0), ref.true_normals(1)])
    run = gm.Playback("three.js", rest=ident, positions=shifted, normals=true)
    row = gm.geometry_row(run, ref)
    assert row["height_m"] == 0.2 and row["rest_identity"] and not row["animated_scale"]
    np.testing.assert_allclose(row["key_dev"], 2e-6, rtol=1e-9)
    assert row["normals_p95"] < 1e-6 and row["key_tol"] == gm.KEY_TOL
    assert any("key frames" in f for f in targets_failed({"ict": [row], "textured": [], "2d": []}))
    # per-corner normals: static (0, 0, 1) at every corner is off where vertex 3 was lifted
    corner_vertex = ref.faces.reshape(-1)
    flat = np.tile([0.0, 0.0, 1.0], (2, corner_vertex.size, 1))
    run = gm.Playback("Blender", rest=ident, positions=ref.positions, normals=flat)
    run.normal_vertex = corner_vertex
    row = gm.geometry_row(run, ref)
    want = np.percentile(gm.angles_deg(flat[1], ref.true_normals(1)[corner_vertex]), 95)
    assert row["normals_p95"] == want > 30 and row["normals_p95_frame"] == 1
    assert targets_failed({"ict": [row], "textured": [], "2d": []}) == []  # Blender: reported


def test_a_compressed_file_is_held_to_the_size_targets_bound():
    ref = _reference()
    ref.extensions = ["KHR_mesh_quantization"]
    assert ref.key_tolerance == gm.COMPRESSED_KEY_TOL == 1e-4
