import numpy as np
import pytest
import trimesh

from conformorph.geometry import MeshError, NotTrianglesError
from conformorph.pipelines.mesh_io import UnsupportedFormatError, read_mesh, write_obj
from tests.meshes import SHARED_FACES, bumpy_disk


@pytest.fixture
def mesh():
    V, F = bumpy_disk(4)
    perm = np.random.default_rng(0).permutation(len(V))  # an order trimesh would not produce
    inv = np.argsort(perm)
    return V[perm], inv[F]


def test_obj_round_trip_keeps_vertex_order(tmp_path, mesh):
    V, F = mesh
    # duplicate vertex: trimesh's default processing would merge it
    V2 = np.vstack([V, V[:1]])
    F2 = np.vstack([F, [[len(V), F[0, 1], F[0, 2]]]])
    p = tmp_path / "m.obj"
    write_obj(p, V2, F2)
    R, G = read_mesh(p)
    np.testing.assert_array_equal(G, F2)
    np.testing.assert_allclose(R, V2, rtol=0, atol=1e-15)


@pytest.mark.parametrize("ftype", ["ply", "off", "stl", "glb"])
def test_other_formats_keep_order(mesh, ftype):
    V, F = mesh
    data = trimesh.Trimesh(V, F, process=False).export(file_type=ftype)
    data = data if isinstance(data, bytes) else data.encode()
    R, G = read_mesh(data, ftype)
    if ftype == "stl":  # STL stores corners, merged back in order of first appearance
        np.testing.assert_allclose(R[G], V[F], atol=1e-6)
    else:
        np.testing.assert_array_equal(G, F)
        np.testing.assert_allclose(R, V, atol=1e-6)


def test_bad_input(tmp_path):
    with pytest.raises(UnsupportedFormatError, match="unsupported mesh type 'xyz'"):
        read_mesh(b"1 2 3", "xyz")
    with pytest.raises(MeshError):
        read_mesh(b"this is not a mesh\x00\x01", "glb")
    with pytest.raises(OSError):
        read_mesh(tmp_path / "missing.obj")
    with pytest.raises(UnsupportedFormatError, match="file_type"):
        read_mesh(b"v 0 0 0")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "line 4: face refers to vertex 4, but only 3"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "line 4: face refers to vertex -4, but only 3"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "line 4: face corner 'x' is not an index"),
    ],
)
def test_bad_obj_face_reference_names_the_line(text, message):
    with pytest.raises(UnsupportedFormatError, match=message):
        read_mesh(text, "obj")


def test_text_without_a_mesh_says_so():
    with pytest.raises(MeshError, match="no mesh"):
        read_mesh(b"garbage\n", "obj")


@pytest.mark.skipif(not SHARED_FACES.exists(), reason="../shared/data is absent")
def test_shared_obj_vertex_count_matches_file():
    V, F = read_mesh(SHARED_FACES / "ict_generic_neutral.obj")
    assert V.shape == (7025, 3) and F.shape == (13910, 3)


def test_gltf_with_external_buffers_is_read_from_its_folder(tmp_path, mesh):
    V, F = mesh
    files = trimesh.Trimesh(V, F, process=False).export(file_type="gltf")
    assert any(name.endswith(".bin") for name in files)  # trimesh writes external buffers
    for name, blob in files.items():
        (tmp_path / name).write_bytes(blob)
    R, G = read_mesh(tmp_path / "model.gltf")
    np.testing.assert_array_equal(G, F)  # vertex order kept (process=False)
    np.testing.assert_allclose(R, V, atol=1e-6)
    # the same document as bytes (an upload) cannot bring its .bin: say so
    with pytest.raises(
        UnsupportedFormatError, match=r"data outside itself \(buffers\[0\]\.uri\).*embed"
    ):
        read_mesh(files["model.gltf"], "gltf")
    # and a .bin missing beside the .gltf is named, with the folder
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "model.gltf").write_bytes(files["model.gltf"])
    with pytest.raises(
        UnsupportedFormatError, match=r"external buffer '.*\.bin', which is not beside it"
    ):
        read_mesh(lone / "model.gltf")


def test_gltf_with_embedded_buffers_reads_from_bytes(mesh):
    V, F = mesh
    data = trimesh.Trimesh(V, F, process=False).export(file_type="gltf", embed_buffers=True)
    R, G = read_mesh(data["model.gltf"], "gltf")
    np.testing.assert_array_equal(G, F)
    np.testing.assert_allclose(R, V, atol=1e-6)


QUAD_V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 2, 0]])


def _binary_ply(faces, order="<"):
    endian = "little" if order == "<" else "big"
    header = (
        f"ply\nformat binary_{endian}_endian 1.0\ncomment written by hand\n"
        "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\nproperty uchar flags\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    body = QUAD_V.astype(order + "f4").tobytes()
    for f in faces:
        body += bytes([7, len(f)]) + np.asarray(f, order + "i4").tobytes()
    return header.encode() + body


@pytest.mark.parametrize(
    ("data", "ftype", "message"),
    [
        (
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\n# quad\nf 1 3 4 2\n",
            "obj",
            "line 7: face 1 has 4 corners",
        ),
        (
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 2 0\nf 1 2 3 4 5\n",
            "obj",
            "line 6: face 0 has 5 corners",
        ),
        (
            b"OFF\n# c\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 0\n3 1 4 2\n4 0 1 2 3\n",
            "off",
            "line 10: face 1 has 4 corners",
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
            b"property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
            b"end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 0\n3 1 4 2\n4 0 1 2 3\n",
            "ply",
            "face 1 has 4 corners",
        ),
        (_binary_ply([[0, 1, 2, 3], [1, 4, 2, 3]]), "ply", "face 0 has 4 corners"),  # all quads
        (_binary_ply([[1, 4, 2], [0, 1, 2, 3]]), "ply", "face 1 has 4 corners"),  # mixed
        (_binary_ply([[1, 4, 2], [0, 1, 2, 3]], ">"), "ply", "face 1 has 4 corners"),
    ],
)
def test_polygon_faces_are_not_triangles(data, ftype, message):
    # trimesh triangulates these silently; the file's own faces are checked
    with pytest.raises(NotTrianglesError, match=message + ".*only triangles"):
        read_mesh(data, ftype)


def test_hand_written_triangle_ply_still_reads():
    R, G = read_mesh(_binary_ply([[1, 4, 2], [0, 1, 2]], ">"), "ply")
    np.testing.assert_array_equal(G, [[1, 4, 2], [0, 1, 2]])
    np.testing.assert_array_equal(R, QUAD_V)
