import numpy as np
import pytest
import trimesh

from geometry import MeshError
from tests.meshes import SHARED_FACES, bumpy_disk
from worker.mesh_io import UnsupportedFormatError, read_mesh, write_obj


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
