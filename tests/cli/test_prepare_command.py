"""``conformorph prepare`` and ``--prepare auto`` on ``map`` and ``reconstruct``."""

import json

import numpy as np

from conformorph.cli.main import main
from conformorph.pipelines.mesh_io import read_mesh, write_obj
from tests.meshes import bumpy_disk
from tests.pipelines.test_preparation import raw_scan


def _scan(tmp_path):
    V, F, facts = raw_scan()
    path = tmp_path / "scan.obj"
    write_obj(path, V, F)
    return path, V, F, facts


def test_prepare_writes_mesh_report_and_vertex_map(tmp_path, capsys):
    path, V, F, facts = _scan(tmp_path)
    out = tmp_path / "out.obj"
    assert main(["prepare", str(path), "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    W, G = read_mesh(out)
    assert report["output"] == {"vertices": W.shape[0], "faces": G.shape[0]}
    assert report["dropped_components"] == [{"vertices": 4, "faces": 2}]
    side = json.loads((tmp_path / "out.obj.prepare.json").read_text())
    vmap = np.array(side["vertex_map"])
    assert vmap.shape == (W.shape[0],) and report["vertex_map_file"].endswith(".prepare.json")
    np.testing.assert_allclose(W[vmap >= 0], V[vmap[vmap >= 0]], rtol=1e-15)
    assert main(["prepare", str(path), "-o", str(out)]) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith(f"wrote {out}") and "1 holes filled" in line


def test_prepare_exit_codes(tmp_path, capsys):
    closed = tmp_path / "tet.obj"
    T = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    write_obj(closed, T, np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]))
    assert main(["prepare", str(closed), "-o", str(tmp_path / "o.obj")]) == 1
    err = capsys.readouterr().err.strip()
    assert "still not a disk" in err and "closed" in err and "\n" not in err
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    assert main(["prepare", str(bad), "-o", str(tmp_path / "o.obj")]) == 2
    assert "error" in capsys.readouterr().err


def test_map_and_reconstruct_prepare_auto(tmp_path, capsys):
    path, V, F, _ = _scan(tmp_path)
    assert main(["map", str(path), "-o", str(tmp_path / "m.npz")]) == 2  # as read: refused
    capsys.readouterr()
    assert (
        main(["map", str(path), "-o", str(tmp_path / "m.npz"), "--prepare", "auto", "--json"]) == 0
    )
    res = json.loads(capsys.readouterr().out)
    with np.load(tmp_path / "m.npz") as z:
        uv, faces, vmap = z["uv"], z["faces"], z["vertex_map"]
    assert uv.shape[0] == vmap.size == res["vertices"] and faces.shape[0] == res["faces"]
    assert np.abs(np.linalg.norm(uv, axis=1)).max() <= 1 + 1e-9
    assert res["preparation"]["disk"] and res["vertex_map_file"].endswith("m.npz.prepare.json")
    out = tmp_path / "r.obj"
    assert main(["reconstruct", str(path), "-o", str(out), "--prepare", "auto", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    W, _ = read_mesh(out)
    side = json.loads((tmp_path / "r.obj.prepare.json").read_text())
    assert len(side["vertex_map"]) == W.shape[0] and res["relative_error"]["L2"] < 1e-2


def test_prepare_auto_on_a_clean_disk_changes_nothing(tmp_path, capsys):
    V, F = bumpy_disk(6)
    path = tmp_path / "d.obj"
    write_obj(path, V, F)
    assert main(["map", str(path), "-o", str(tmp_path / "a.npz"), "--prepare", "auto"]) == 0
    assert main(["map", str(path), "-o", str(tmp_path / "b.npz")]) == 0
    with np.load(tmp_path / "a.npz") as a, np.load(tmp_path / "b.npz") as b:
        assert "vertex_map" not in a.files
        np.testing.assert_array_equal(a["uv"], b["uv"])
        np.testing.assert_array_equal(a["faces"], F)
    assert not (tmp_path / "a.npz.prepare.json").exists()


def test_prepare_cuts_the_face_out_of_a_closed_head(tmp_path, capsys):
    from tests.meshes import FIXTURES, closed_head

    path = FIXTURES / "closed_head.obj"
    V, F = read_mesh(path)
    W0, G0 = closed_head(rings=11, sectors=24)  # the committed file is this mesh
    np.testing.assert_allclose(V, 100 * W0, atol=1e-6)
    np.testing.assert_array_equal(F, G0)
    out = tmp_path / "face.obj"
    assert main(["prepare", str(path), "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    cut = report["face_cut"]
    assert report["disk"] and report["problem"] is None and not cut["from_landmarks"]
    W, G = read_mesh(out)
    assert cut["kept_faces"] == G.shape[0] and cut["removed_faces"] == F.shape[0] - G.shape[0]
    vmap = np.array(json.loads((tmp_path / "face.obj.prepare.json").read_text())["vertex_map"])
    np.testing.assert_allclose(W, V[vmap], atol=1e-12)
    assert cut["centre_vertex_id"] == int(np.argmax(V[:, 2]))  # the nose tip
    # the front only: the cut pushed out toward the reach, which on this near-sphere lies
    # at its equator (z = 0); nothing behind it
    assert int(np.argmax(V[:, 2])) in vmap and V[vmap, 2].min() >= 0
    from conformorph import geometry

    geometry.validate_mesh(W, G, require_disk=True)
    assert main(["prepare", str(path), "-o", str(out)]) == 0
    assert f"face cut out ({G.shape[0]} faces kept" in capsys.readouterr().out


def test_prepare_landmarks_place_the_face_and_are_remapped(tmp_path, capsys):
    from tests.meshes import FIXTURES

    path = FIXTURES / "closed_head.obj"
    V, _ = read_mesh(path)
    tip = int(np.argmax(V[:, 2]))
    near = [int(i) for i in np.argsort(np.linalg.norm(V - V[tip], axis=1))[1:20:4]]
    point = (V[near[-1]] + [0.0, 0.0, 0.5]).tolist()  # off the surface by 0.5 mm
    lm = tmp_path / "lm.json"
    lm.write_text(json.dumps({"landmarks": [[*near[:-1], point]]}))
    out = tmp_path / "face.obj"
    assert main(["prepare", str(path), "-o", str(out), "--landmarks", str(lm), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["disk"] and report["face_cut"]["from_landmarks"]
    W, _ = read_mesh(out)
    rows = report["landmark_rows"]
    assert len(rows) == len(near) and min(rows) >= 0
    np.testing.assert_allclose(W[rows], V[near], atol=1e-9)  # the point: its nearest vertex
    lm.write_text(json.dumps({"landmarks": [[1, 2, 10_000]]}))
    assert main(["prepare", str(path), "-o", str(out), "--landmarks", str(lm)]) == 2
    assert "out of range" in capsys.readouterr().err
