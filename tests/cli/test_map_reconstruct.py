import json

import numpy as np
import pytest

from conformorph import geometry
from conformorph.cli.main import main
from conformorph.pipelines.mesh_io import read_mesh, write_obj
from tests.meshes import bumpy_disk, disk_grid, eared_disk, folded_bumpy_disk

#: 3 vertices, and a face that names vertex 7
BAD_INDEX_PLY = (
    b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
    b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    b"0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"
)


def _one_line_error(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err
    return err


def _holed_bumpy_disk():
    """bumpy_disk's grid with the centre vertex's fan removed: one hole, vertex order kept."""
    V, F = disk_grid(6)
    V[:, 2] = 0.3 * np.exp(-3 * (V[:, 0] ** 2 + V[:, 1] ** 2))
    centre = int(np.argmin(np.hypot(V[:, 0], V[:, 1])))
    F = F[~np.any(F == centre, axis=1)]
    keep = np.unique(F)
    remap = np.full(len(V), -1)
    remap[keep] = np.arange(len(keep))
    return V[keep], remap[F]


def test_map_writes_npz_and_json(tmp_path, capsys):
    V, F = bumpy_disk(6)
    src = tmp_path / "face.obj"
    write_obj(src, V, F)
    out = tmp_path / "map.npz"
    assert main(["map", str(src), "-o", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    with np.load(out) as z:
        assert z["uv"].shape == (len(V), 2)
        np.testing.assert_array_equal(z["faces"], F)
    assert result["flipped_triangles"] == 0
    assert result["mean_angle_distortion_deg"] < 2
    assert set(result["info"]["seconds"]) >= {"factor", "solve"}
    # boundary circularity is measured (it was null: map_quality got no boundary)
    q = result["quality"]
    assert q["boundary_circle_error"] is not None and q["boundary_circle_error"] <= 1e-9
    ratio = q["boundary_isoperimetric_ratio"]
    assert ratio is not None and 0.99 < ratio <= 1.0  # a polygon inscribed in the unit circle
    assert result["info"]["extra"]["angle_refinement"]["step"] > 0
    # --no-angle-refinement: the harmonic map, with more angle distortion
    plain = tmp_path / "plain.npz"
    assert main(["map", str(src), "-o", str(plain), "--json", "--no-angle-refinement"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert "angle_refinement" not in got["info"]["extra"]
    assert got["mean_angle_distortion_deg"] > result["mean_angle_distortion_deg"]


def test_reconstruct_keeps_order_and_reports_errors(tmp_path, capsys):
    V, F = bumpy_disk(8)
    src = tmp_path / "face.obj"
    write_obj(src, V, F)
    out = tmp_path / "rec.obj"
    assert main(["reconstruct", str(src), "-o", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    X, G = read_mesh(out)
    np.testing.assert_array_equal(G, F)
    assert result["relative_error"]["L2"] < 5e-3
    assert np.linalg.norm(X - V, axis=1).max() < 0.05


def test_reconstruct_corrects_the_folded_maps_region_unless_told_not_to(tmp_path, capsys):
    V, F = folded_bumpy_disk()
    src = tmp_path / "folded.obj"
    write_obj(src, V, F)
    runs = {}
    for flag in ([], ["--no-fold-correction"]):
        assert main(["reconstruct", str(src), "-o", str(tmp_path / "r.obj"), "--json", *flag]) == 0
        runs[bool(flag)] = json.loads(capsys.readouterr().out)
    corrected, plain = runs[False], runs[True]
    assert corrected["map_flipped_triangles"] > 0
    assert corrected["reconstruction"]["fold_correction"]["vertices"] > 0
    assert plain["reconstruction"]["fold_correction"] is None
    assert corrected["relative_error"]["Linf"] < plain["relative_error"]["Linf"] / 10


def test_bad_input_exits_2_with_one_line(tmp_path, capsys):
    V, F = bumpy_disk(4)
    src = tmp_path / "two.obj"
    write_obj(src, np.vstack([V, V + 5]), np.vstack([F, F + len(V)]))
    assert main(["map", str(src), "-o", str(tmp_path / "x.npz")]) == 2
    err = capsys.readouterr().err.strip()
    assert "2 connected components" in err and "\n" not in err and "Traceback" not in err
    assert main(["map", str(tmp_path / "nope.obj"), "-o", str(tmp_path / "x.npz")]) == 2
    assert not (tmp_path / "x.npz").exists()


def test_remove_ears_option(tmp_path, capsys):
    V, F = bumpy_disk(5)
    from conformorph.geometry import boundary_loop

    b = boundary_loop(F)
    V2 = np.vstack([V, 0.65 * (V[b[0]] + V[b[1]])])
    F2 = np.vstack([F, [[b[1], b[0], len(V)]]])
    src = tmp_path / "ears.obj"
    write_obj(src, V2, F2)
    assert main(["map", str(src), "-o", str(tmp_path / "m.npz")]) == 2
    assert "ears" in capsys.readouterr().err
    assert main(["map", str(src), "-o", str(tmp_path / "m.npz"), "--remove-ears", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["removed_ear_vertices"] >= 1


def test_remove_ears_keeps_the_input_vertices_in_map_and_reconstruct(tmp_path, capsys):
    V, F, ears = eared_disk()
    src = tmp_path / "ears.obj"
    write_obj(src, V, F)
    out = tmp_path / "m.npz"
    assert main(["map", str(src), "-o", str(out), "--remove-ears", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["removed_ear_vertex_ids"] == ears.tolist()  # two rounds: both ears
    assert (result["vertices"], result["mapped_vertices"]) == (len(V), len(V) - 2)
    with np.load(out) as z:
        uv, faces, kept = z["uv"], z["faces"], z["kept"]
    # the input's vertex count, order and faces
    assert uv.shape == (len(V), 2)
    np.testing.assert_array_equal(faces, F)
    np.testing.assert_array_equal(np.flatnonzero(~kept), ears)
    # the kept rows are the map of the repaired mesh, in input order
    V2, F2, idx = geometry.remove_boundary_ears(V, F)
    uv2, _ = geometry.disk_conformal_map(V2, F2)
    np.testing.assert_allclose(uv[idx], uv2, atol=1e-12)
    # the ears are back on the unit circle and nothing is folded: a disk map of the input
    np.testing.assert_allclose(np.hypot(*uv[ears].T), 1.0, atol=1e-12)
    assert not geometry.flipped_triangles(uv, F).any()

    rec = tmp_path / "r.obj"
    assert main(["reconstruct", str(src), "-o", str(rec), "--remove-ears", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["removed_ear_vertex_ids"] == ears.tolist()
    X, G = read_mesh(rec)
    assert X.shape == V.shape
    np.testing.assert_array_equal(G, F)
    np.testing.assert_array_equal(X[ears], V[ears])  # removed ears keep their input positions
    assert np.linalg.norm(X - V, axis=1).max() < 0.05


def test_fill_holes_outputs_keep_the_input_vertices_and_faces(tmp_path, capsys):
    V, F = _holed_bumpy_disk()
    src = tmp_path / "hole.obj"
    write_obj(src, V, F)
    assert main(["map", str(src), "-o", str(tmp_path / "m.npz")]) == 2
    _one_line_error(capsys, "2 boundary loops", "--fill-holes")
    assert main(["map", str(src), "-o", str(tmp_path / "m.npz"), "--fill-holes", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["filled_holes"] == 1 and result["mapped_vertices"] == len(V) + 1
    with np.load(tmp_path / "m.npz") as z:
        assert z["uv"].shape == (len(V), 2) and z["kept"].all()
        np.testing.assert_array_equal(z["faces"], F)
    assert main(["reconstruct", str(src), "-o", str(tmp_path / "r.obj"), "--fill-holes"]) == 0
    capsys.readouterr()
    X, G = read_mesh(tmp_path / "r.obj")
    assert X.shape == V.shape
    np.testing.assert_array_equal(G, F)
    assert np.linalg.norm(X - V, axis=1).max() < 0.05


@pytest.mark.parametrize("command", ["map", "reconstruct"])
@pytest.mark.parametrize(
    "repair", [[], ["--remove-ears"], ["--fill-holes"], ["--remove-ears", "--fill-holes"]]
)
def test_bad_face_index_is_reported_before_any_repair(tmp_path, capsys, command, repair):
    src = tmp_path / "bad.ply"
    src.write_bytes(BAD_INDEX_PLY)
    out = tmp_path / ("x.npz" if command == "map" else "x.obj")
    assert main([command, str(src), "-o", str(out), *repair]) == 2
    _one_line_error(capsys, "outside 0..2", "face 0 is [0, 1, 7]")
    assert not out.exists()


def test_reconstruct_of_one_triangle_says_why_not(tmp_path, capsys):
    src = tmp_path / "tri.obj"
    write_obj(src, np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    assert main(["map", str(src), "-o", str(tmp_path / "t.npz")]) == 0  # the map is fine
    capsys.readouterr()
    assert main(["reconstruct", str(src), "-o", str(tmp_path / "t.obj")]) == 2
    _one_line_error(capsys, "needs interior vertices", "all 3 vertices")
    assert not (tmp_path / "t.obj").exists()


def test_quads_are_refused_with_their_line(tmp_path, capsys):
    src = tmp_path / "quad.obj"
    src.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    assert main(["map", str(src), "-o", str(tmp_path / "q.npz")]) == 2
    _one_line_error(capsys, "line 5: face 0 has 4 corners")
