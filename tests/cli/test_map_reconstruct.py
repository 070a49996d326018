import json

import numpy as np

from cli.main import main
from tests.meshes import bumpy_disk
from worker.mesh_io import read_mesh, write_obj


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
    from geometry import boundary_loop

    b = boundary_loop(F)
    V2 = np.vstack([V, 0.65 * (V[b[0]] + V[b[1]])])
    F2 = np.vstack([F, [[b[1], b[0], len(V)]]])
    src = tmp_path / "ears.obj"
    write_obj(src, V2, F2)
    assert main(["map", str(src), "-o", str(tmp_path / "m.npz")]) == 2
    assert "ears" in capsys.readouterr().err
    assert main(["map", str(src), "-o", str(tmp_path / "m.npz"), "--remove-ears", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["removed_ear_vertices"] >= 1
