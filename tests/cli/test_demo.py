import json

import numpy as np
from PIL import Image

from conformorph.cli.cmd_demo import CHECK_COLOURS, DEMO_FACE, rasterize
from conformorph.cli.main import main
from conformorph.geometry.boundary_loop import boundary_loop
from conformorph.geometry.validate_mesh import validate_mesh
from conformorph.pipelines.mesh_io import read_mesh, write_obj
from tests.meshes import bumpy_disk


def test_bundled_face_is_a_clean_disk():
    V, F = read_mesh(DEMO_FACE)
    report = validate_mesh(V, F, require_disk=True)
    assert 1000 <= report.n_vertices <= 3000
    assert (DEMO_FACE.parent / "README.md").read_text().count("Apache") >= 1


def test_demo_writes_figure_outputs_and_json(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert json.loads((out / "demo.json").read_text()) == result
    q = result["quality"]
    assert q["flipped"] == 0 and q["angle_distortion_mean"] < 1.5
    assert q["boundary_circle_error"] <= 1e-9
    assert result["relative_error"]["L2"] < 2e-3
    V, F = read_mesh(DEMO_FACE)
    with np.load(out / "demo_map.npz") as z:
        uv = z["uv"]
        np.testing.assert_array_equal(z["faces"], F)
    b = boundary_loop(F)
    assert np.abs(np.hypot(*uv[b].T) - 1).max() <= 1e-9
    X, G = read_mesh(out / "demo_reconstructed.obj")
    np.testing.assert_array_equal(G, F)
    assert X.shape == V.shape
    # the figure: four panels; panel (b), the face, shows both checkerboard colours, shaded
    im = np.asarray(Image.open(out / "demo_figure.png").convert("RGB")).astype(float)
    assert im.shape[1] == 4 * 420 and im.shape[0] == 460
    face = im[40:, 420:840].reshape(-1, 3)
    for colour in CHECK_COLOURS:
        direction = colour / np.linalg.norm(colour)
        cos = face @ direction / np.maximum(np.linalg.norm(face, axis=1), 1e-9)
        is_white = np.all(face == 255, axis=1)
        assert np.count_nonzero((cos > 0.999) & ~is_white) > 1000


def test_demo_on_another_mesh_and_bad_input(tmp_path, capsys):
    V, F = bumpy_disk(6)
    src = tmp_path / "bump.obj"
    write_obj(src, V, F)
    assert main(["demo", "-o", str(tmp_path / "o"), "--mesh", str(src), "--method", "fast"]) == 0
    assert "flipped" in capsys.readouterr().out
    # an ear vertex is refused, and accepted with --remove-ears
    b = boundary_loop(F)
    ear = np.vstack([V, 0.65 * (V[b[0]] + V[b[1]])])
    write_obj(src, ear, np.vstack([F, [[b[1], b[0], len(V)]]]))
    assert main(["demo", "-o", str(tmp_path / "o1"), "--mesh", str(src)]) == 2
    assert "ears" in capsys.readouterr().err
    assert main(["demo", "-o", str(tmp_path / "o1"), "--mesh", str(src), "--remove-ears"]) == 0
    capsys.readouterr()
    # the outputs keep the input's vertices and faces: the ear is back (uv on the circle,
    # reconstructed at its input position) and marked in `kept`
    with np.load(tmp_path / "o1" / "demo_map.npz") as z:
        assert z["uv"].shape == (len(V) + 1, 2)
        np.testing.assert_array_equal(np.flatnonzero(~z["kept"]), [len(V)])
        np.testing.assert_array_equal(z["faces"], np.vstack([F, [[b[1], b[0], len(V)]]]))
        assert abs(np.hypot(*z["uv"][len(V)]) - 1) < 1e-12
    X, G = read_mesh(tmp_path / "o1" / "demo_reconstructed.obj")
    assert X.shape == ear.shape and len(G) == len(F) + 1
    np.testing.assert_array_equal(X[len(V)], ear[len(V)])
    summary = json.loads((tmp_path / "o1" / "demo.json").read_text())
    assert summary["removed_ear_vertex_ids"] == [len(V)] and summary["vertices"] == len(V) + 1
    # a single triangle has nothing to reconstruct: said in one line
    write_obj(src, V[F[0]], np.array([[0, 1, 2]]))
    assert main(["demo", "-o", str(tmp_path / "o3"), "--mesh", str(src)]) == 2
    err = capsys.readouterr().err.strip()
    assert "needs interior vertices" in err and "\n" not in err
    write_obj(src, np.vstack([V, V + 3]), np.vstack([F, F + len(V)]))
    assert main(["demo", "-o", str(tmp_path / "o2"), "--mesh", str(src)]) == 2
    err = capsys.readouterr().err.strip()
    assert "components" in err and "\n" not in err and "Traceback" not in err


def test_rasterize_one_triangle_by_hand():
    # the lower-left half of an 8×8 image; attribute = x, interpolated exactly
    P = np.array([[0.0, 0.0], [8.0, 0.0], [0.0, 8.0]])
    img, fid = rasterize(P, np.zeros(3), np.array([[0, 1, 2]]), P[:, :1], 8)
    covered = fid == 0
    ys, xs = np.nonzero(covered)
    assert np.all(xs + ys <= 8)  # on or below the hypotenuse x + y = 8
    assert 28 <= covered.sum() <= 45  # half of 64 pixels, up to the fill rule on the edges
    inside = xs + ys <= 6  # pixel centre strictly inside: the attribute is exact
    np.testing.assert_allclose(img[covered, 0][inside], xs[inside] + 0.5)
    assert fid[7, 7] == -1 and np.all(img[~covered] == 0)


def test_rasterize_draws_nearer_triangles_over_farther_ones():
    P = np.array([[0.0, 0.0], [6.0, 0.0], [0.0, 6.0], [6.0, 6.0]])
    F = np.array([[0, 1, 2], [1, 3, 2], [0, 1, 3]])
    depth = np.array([0.0, 0.0, 0.0, 1.0])
    # face 2 (mean depth 1/3) covers the region y < x and is drawn over faces 0 and 1
    _, fid = rasterize(P, depth, F, np.zeros((4, 1)), 6)
    assert fid[1, 5] == 2 and fid[4, 5] == 2 and fid[4, 0] == 0 and fid[5, 3] == 1
