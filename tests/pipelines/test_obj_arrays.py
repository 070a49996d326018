"""The plain-OBJ reader gives what trimesh gives, and hands every other file to trimesh."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from conformorph.pipelines.mesh_file_checks import MeshLimits, MeshTooLargeError, check_mesh_file
from conformorph.pipelines.mesh_io import read_mesh
from conformorph.pipelines.obj_arrays import (
    MAX_PLAIN_OBJ_BYTES,
    plain_obj_arrays,
    simple_obj_arrays,
)

ROOT = Path(__file__).resolve().parents[2]
SHARED_FACES = ROOT.parent / "shared" / "data" / "faces"


def _trimesh_arrays(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    m = trimesh.load(
        io.BytesIO(data), file_type="obj", process=False, maintain_order=True, skip_materials=True
    )
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def _obj_files() -> list[Path]:
    files = sorted((ROOT / "tests" / "fixtures").rglob("*.obj"))
    if SHARED_FACES.is_dir():
        files += sorted(SHARED_FACES.glob("*.obj"))
    return files


def test_hand_worked_file_with_uvs_normals_and_colours():
    data = (
        b"# a quad as two triangles\n"
        b"v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0\nv 0 1 0\n"
        b"vt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n"
        b"f 1/1/1 2/2/1 3/3/1\nf 1//1 3//1 4//1\n"
    )
    V, F = plain_obj_arrays(data)
    assert V.dtype == np.float64 and F.dtype == np.int64
    np.testing.assert_array_equal(V, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(F, [[0, 1, 2], [0, 2, 3]])


@pytest.mark.parametrize("path", _obj_files(), ids=lambda p: p.name)
def test_same_arrays_as_trimesh_on_every_committed_and_shared_obj(path):
    data = path.read_bytes()
    got = plain_obj_arrays(data)
    V, F = _trimesh_arrays(data)
    if got is not None:
        np.testing.assert_array_equal(got[0], V)
        np.testing.assert_array_equal(got[1], F)
    # and read_mesh, which takes this path or trimesh's, agrees too
    V2, F2 = read_mesh(path)
    np.testing.assert_array_equal(V2, V)
    np.testing.assert_array_equal(F2, F)


def test_the_committed_and_ict_faces_are_plain():
    plain = [p for p in _obj_files() if p.parent.name != "faces" or p.name.startswith("ict_")]
    assert plain and all(plain_obj_arrays(p.read_bytes()) is not None for p in plain)


@pytest.mark.parametrize(
    "data",
    [
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",  # relative indices
        b"o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # an object
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\ng part\nf 1 2 3\n",  # a group
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl skin\nf 1 2 3\n",  # a material
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \\\n3\n",  # a continuation line
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\n",  # no face
        b"v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a short vertex line
        b"v 0 0 x\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # not a number
    ],
)
def test_anything_but_a_plain_file_goes_to_trimesh(data):
    assert plain_obj_arrays(data) is None


def test_a_large_file_goes_to_trimesh():
    line = b"v 0.000000000 0.000000000 0.000000000\n"
    data = line * (MAX_PLAIN_OBJ_BYTES // len(line) + 1) + b"f 1 2 3\n"
    assert plain_obj_arrays(data) is None


def test_input_bytes_are_not_changed():
    data = bytearray(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    before = bytes(data)
    plain_obj_arrays(bytes(data))
    assert bytes(data) == before


def test_reading_a_plain_obj_imports_no_trimesh(tmp_path):
    path = tmp_path / "t.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    code = (
        "import sys\nfrom conformorph.pipelines.mesh_io import read_mesh\n"
        f"V, F = read_mesh({str(path)!r})\n"
        "print(V.shape, F.tolist(), 'trimesh' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "(3, 3) [[0, 1, 2]] False"


def test_two_block_layout_read_without_splitting_lines():
    from conformorph.pipelines.obj_arrays import _two_blocks, plain_obj_in_order

    data = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.5\nf 1 2 3\nf 2 4 3"
    V, F = _two_blocks(data)
    np.testing.assert_array_equal(F, [[0, 1, 2], [1, 3, 2]])
    np.testing.assert_array_equal(V, _trimesh_arrays(data)[0])
    assert plain_obj_in_order(data, F, 4)
    # anything else is left to the line-by-line reader, which gives the same arrays
    for other in (
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n",  # slashes
        b"v 0 0 0\nvn 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a normal among the vertices
        b"v 0 0 0 # origin\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a comment
    ):
        assert _two_blocks(other) is None
        np.testing.assert_array_equal(plain_obj_arrays(other)[1], [[0, 1, 2]])
    assert _two_blocks(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 1\n") is None  # a quad
    assert plain_obj_arrays(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 1\n") is None
    # a vertex after the first face: checked line by line
    late = b"v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n"
    assert not plain_obj_in_order(late, np.array([[0, 1, 2]]), 3)


def _checked_plain(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """The line-by-line path: the structure checks, then the plain reader."""
    check_mesh_file(data, "obj", MeshLimits())
    got = plain_obj_arrays(data)
    assert got is not None
    return got


def test_simple_reader_hand_worked_file():
    data = b"v 0 0 0\r\nv 1.5 -2e-3 .25\r\n\r\nv 0 1 0\r\nf 1 2 3\r\nv 7 8 9\r\nf 4 3 2"
    V, F = simple_obj_arrays(data)
    assert V.dtype == np.float64 and F.dtype == np.int64
    np.testing.assert_array_equal(V, [[0, 0, 0], [1.5, -2e-3, 0.25], [0, 1, 0], [7, 8, 9]])
    np.testing.assert_array_equal(F, [[0, 1, 2], [3, 2, 1]])


def test_simple_reader_gives_the_line_by_line_arrays_bit_for_bit():
    # numbers written every way a writer might: repr, %.17g, %.6e, fixed, integers, signs
    rng = np.random.default_rng(0)
    X = (rng.standard_normal((300, 3)) * 10.0 ** rng.integers(-12, 12, (300, 1))).tolist()
    forms = ["{!r}", "{:.17g}", "{:.6e}", "{:.4f}", "{:+.3E}", "{:.0f}"]
    lines = [
        "v " + " ".join(forms[(i + j) % len(forms)].format(x) for j, x in enumerate(row))
        for i, row in enumerate(X)
    ]
    lines += [f"f {a} {b} {c}" for a, b, c in rng.integers(1, 301, (500, 3))]
    data = ("\n".join(lines) + "\n").encode()
    V, F = simple_obj_arrays(data)
    V0, F0 = _checked_plain(data)
    assert V.tobytes() == V0.tobytes()
    np.testing.assert_array_equal(F, F0)


@pytest.mark.parametrize("path", _obj_files(), ids=lambda p: p.name)
def test_simple_reader_agrees_with_the_plain_reader_on_every_obj(path):
    data = path.read_bytes()
    got = simple_obj_arrays(data)
    if got is not None and len(data) <= MAX_PLAIN_OBJ_BYTES:
        V0, F0 = _checked_plain(data)
        assert got[0].tobytes() == V0.tobytes()
        np.testing.assert_array_equal(got[1], F0)


@pytest.mark.parametrize(
    "data",
    [
        b"# c\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a comment
        b" v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # keyword not at the line start
        b"v\t0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a tab after the keyword
        b"v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a vertex colour
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n",  # texture indices
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 1\n",  # a quad
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",  # index past the vertices
        b"v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n",  # vertex defined after the face
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",  # index 0
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf +1 2 3\n",  # a signed index
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",  # relative indices
        b"v 0 0 1e\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # not a number
        b"v 0 0 1-2\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # not a number
        b"v 0 0 0\rv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a lone carriage return
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\n",  # no face
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",  # too many digits
        b"",
    ],
)
def test_simple_reader_leaves_everything_else_to_the_line_checks(data):
    assert simple_obj_arrays(data) is None


def test_read_mesh_checks_the_limits_on_the_simple_path(tmp_path):
    path = tmp_path / "t.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert simple_obj_arrays(path.read_bytes()) is not None
    with pytest.raises(MeshTooLargeError):
        read_mesh(path, limits=MeshLimits(max_vertices=2))
    V, F = read_mesh(path, limits=MeshLimits(max_vertices=3))
    assert V.shape == (3, 3) and F.tolist() == [[0, 1, 2]]
