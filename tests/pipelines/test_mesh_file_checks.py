"""Declared counts, sizes and references checked against the real bytes (issue 15, items 1, 6, 11)."""

from __future__ import annotations

import json
import os
import struct

import numpy as np
import pytest
import trimesh

from conformorph.geometry import NotTrianglesError
from conformorph.pipelines.mesh_io import (
    MalformedMeshFileError,
    MeshLimits,
    MeshTooLargeError,
    UnsupportedFormatError,
    read_mesh,
)
from tests.fixtures.malformed_corpus import valid_disk_files


def _ascii_ply(n_vertices: int | str, n_faces: int | str, faces: list[str]) -> bytes:
    V = np.random.default_rng(0).random((36, 3))
    return (
        f"ply\nformat ascii 1.0\nelement vertex {n_vertices}\nproperty float x\n"
        f"property float y\nproperty float z\nelement face {n_faces}\n"
        "property list uchar int vertex_indices\nend_header\n"
        + "".join(f"{x} {y} {z}\n" for x, y, z in V)
        + "".join(f + "\n" for f in faces)
    ).encode()


TRIANGLES = [f"3 {k} {k + 1} {k + 2}" for k in range(34)]


@pytest.mark.timeout(20)
@pytest.mark.parametrize("count", [2**31, 2**40, 10**12])
def test_a_huge_declared_vertex_count_is_refused_at_once(count):
    # was: the polygon scan looped over the declared count (282 s for 2^31)
    with pytest.raises(MalformedMeshFileError, match=f"declares {count} vertex, 34 face records"):
        read_mesh(_ascii_ply(count, 34, TRIANGLES), "ply")


def test_declared_counts_pass_the_limits_before_parsing():
    with pytest.raises(MeshTooLargeError, match="declares 36 vertices and 34 faces; the limits"):
        read_mesh(_ascii_ply(36, 34, TRIANGLES), "ply", limits=MeshLimits(30, 100))


@pytest.mark.timeout(20)
def test_more_faces_declared_than_given_is_not_read_as_the_faces_given():
    # was: accepted as 34 faces
    with pytest.raises(MalformedMeshFileError, match="2147483648 face records, one line each"):
        read_mesh(_ascii_ply(36, 2**31, TRIANGLES), "ply")


@pytest.mark.timeout(20)
def test_a_face_with_2_to_the_40_corners_is_named():
    faces = [*TRIANGLES[:5], f"{2**40} 0 1 2", *TRIANGLES[6:]]
    with pytest.raises(
        MalformedMeshFileError, match="line 51: face 5 declares 1099511627776 corners but gives 3"
    ):
        read_mesh(_ascii_ply(36, 34, faces), "ply")


def test_obj_vertex_zero_does_not_exist():
    # was: read as [0, 1, 7] (0 taken for the last vertex)
    data = b"".join(b"v %d 0 0\n" % k for k in range(9)) + b"f 0 2 8\n"
    with pytest.raises(
        MalformedMeshFileError, match="line 10: face refers to vertex 0, which does not exist"
    ):
        read_mesh(data, "obj")


def test_off_face_giving_fewer_corners_than_declared():
    # was: read as a triangle
    data = b"OFF\n8 1 0\n" + b"0 0 0\n" * 8 + b"4 0 1 7\n"
    with pytest.raises(
        MalformedMeshFileError, match="line 11: face 0 declares 4 corners but gives 3"
    ):
        read_mesh(data, "off")


@pytest.mark.parametrize("count", [2**31, 10**6, 0])
def test_binary_stl_triangle_count_must_match_the_size(count):
    stl = valid_disk_files()["stl"]
    bad = stl[:80] + struct.pack("<I", count) + stl[84:]
    with pytest.raises(
        MalformedMeshFileError, match=f"declares {count} triangles.*file has {len(stl)}"
    ):
        read_mesh(bad, "stl")


def test_binary_ply_corner_counts_found_without_walking():
    ply = trimesh.Trimesh(*_fan(), process=False).export(file_type="ply")
    head = ply.index(b"end_header\n") + len(b"end_header\n") + 7 * 12
    bad = bytearray(ply)
    bad[head + 13 * 4] = 200  # face 4's corner count
    with pytest.raises(NotTrianglesError, match="face 4 has 200 corners"):
        read_mesh(bytes(bad), "ply")
    with pytest.raises(MalformedMeshFileError, match="ends inside face 5"):
        read_mesh(ply[: head + 13 * 5 + 4], "ply")


def _fan():
    ang = np.arange(6) * np.pi / 3
    V = np.vstack([[0.0, 0, 0], np.c_[np.cos(ang), np.sin(ang), np.zeros(6)]])
    return V, np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)])


def _gltf_with(uri: str) -> bytes:
    doc = json.loads(valid_disk_files()["gltf"])
    doc["buffers"][0]["uri"] = uri
    return json.dumps(doc).encode()


def test_uploaded_gltf_references_all_get_one_message(tmp_path):
    """Absolute or ``../``, existing or missing: one message that names no path."""
    (tmp_path / "x.bin").write_bytes(b"\0" * 4096)
    uris = [str(tmp_path / "x.bin"), str(tmp_path / "missing.bin"), "../x.bin", "/etc/passwd"]
    messages = set()
    for uri in uris:
        with pytest.raises(MalformedMeshFileError) as info:
            read_mesh(_gltf_with(uri), "gltf")
        messages.add(str(info.value))
    assert len(messages) == 1
    (message,) = messages
    assert "buffers[0].uri" in message and str(tmp_path) not in message and "/etc" not in message


def test_a_gltf_on_disk_reads_only_files_in_its_own_folder(tmp_path):
    folder = tmp_path / "model"
    folder.mkdir()
    outside = tmp_path / "outside.bin"
    outside.write_bytes(b"\0" * 4096)
    (folder / "link.bin").symlink_to(outside)
    messages = set()
    for k, uri in enumerate(["../outside.bin", str(outside), "link.bin", "missing.bin"]):
        (folder / f"m{k}.gltf").write_bytes(_gltf_with(uri))
        with pytest.raises(UnsupportedFormatError, match="which is not beside it") as info:
            read_mesh(folder / f"m{k}.gltf")
        messages.add(str(info.value).replace(repr(uri[:80]), "URI"))
    assert len(messages) == 1
    assert os.fspath(tmp_path) not in messages.pop()


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        ("accessors.0.count", 10**12, r"accessors\[0\] declares 1000000000000 elements"),
        ("bufferViews.0.byteLength", 2**40, r"bufferViews\[0\] spans bytes"),
        (
            "buffers.0.byteLength",
            2**40,
            r"buffers\[0\].byteLength is 1099511627776 but its data has",
        ),
        ("accessors.0.bufferView", 5, r"accessors\[0\].bufferView names no buffer view"),
    ],
)
def test_gltf_lengths_and_counts_are_checked_against_the_data(path, value, message):
    doc = json.loads(valid_disk_files()["gltf"])
    key, index, field = path.split(".")
    doc[key][int(index)][field] = value
    with pytest.raises(MalformedMeshFileError, match=message):
        read_mesh(json.dumps(doc).encode(), "gltf")


def test_glb_chunk_lengths_are_checked_against_the_file():
    glb = valid_disk_files()["glb"]
    with pytest.raises(MalformedMeshFileError, match=f"declares {2**31} bytes but the file has"):
        read_mesh(glb[:8] + struct.pack("<I", 2**31) + glb[12:], "glb")
    with pytest.raises(MalformedMeshFileError, match="chunk 0 declares 4294967295 bytes"):
        read_mesh(glb[:12] + struct.pack("<I", 2**32 - 1) + glb[16:], "glb")


@pytest.mark.parametrize(
    "reason", ["", "'NoneType' object is not subscriptable", "list index out of range"]
)
def test_unparseable_files_never_show_the_parser_s_own_text(monkeypatch, reason):
    # was: "cannot parse the GLB file: " followed by trimesh's text, sometimes empty
    def fail(*_args, **_kwargs):
        raise (IndexError if "index" in reason else TypeError)(reason)

    monkeypatch.setattr(trimesh, "load", fail)
    with pytest.raises(UnsupportedFormatError) as info:
        read_mesh(valid_disk_files()["glb"], "glb")
    message = str(info.value)
    assert message.startswith("cannot parse the GLB file: its contents are not a valid GLB mesh")
    assert reason not in message or not reason


def test_bad_json_in_a_glb_says_where():
    glb = valid_disk_files()["glb"]
    with pytest.raises(MalformedMeshFileError, match=r"not valid JSON \(line 1, column 1\)"):
        read_mesh(glb[:20] + b"}" + glb[21:], "glb")
