"""``conformorph morph --fill-holes`` (and the not-a-disk message that offers it)."""

import json

import numpy as np

from conformorph.cli.main import main
from conformorph.pipelines.face_morph.key_preparation import fill_key_holes
from tests.pipelines.face_fixtures import face_mesh, write_obj


def _holed_faces(tmp_path):
    """Two fixture faces with the same hole (one vertex's fan removed), and their landmarks."""
    paths, lms = [], []
    for i, smile in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(smile)
        if i == 0:
            # the vertex nearest a point between the eyes and the nose, not a landmark
            c = int(np.argmin(np.linalg.norm(V[:, :2] - [0.0, 0.2], axis=1)))
            assert c not in lm
        F = F[~np.any(F == c, axis=1)]
        F = F - (F > c)  # drop vertex c, keep the others' order
        V = np.delete(V, c, axis=0)
        paths.append(str(write_obj(tmp_path / f"h{i}.obj", V, F)))
        lms.append([j - (j > c) for j in lm])
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    return paths, str(L), V.shape[0]


def test_morph_fills_holes_when_asked(tmp_path, capsys):
    paths, L, n = _holed_faces(tmp_path)
    args = ["morph", *paths, "--landmarks", L, "--frames", "2", "--no-metrics"]
    assert main([*args, "--prepare", "none", "-o", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err.strip()
    assert "2 boundary loops" in err and "--fill-holes" in err and "\n" not in err
    assert (
        main([*args, "--prepare", "none", "--fill-holes", "-o", str(tmp_path / "b"), "--json"]) == 0
    )
    metrics = json.loads(capsys.readouterr().out)
    assert (tmp_path / "b" / "animation.glb").is_file()
    assert metrics["frame_times"] == [0.0, 1.0]


def test_morph_prepares_by_default(tmp_path, capsys):
    """``--prepare auto`` (the default) fills the hole with a faired patch and says so."""
    paths, L, n = _holed_faces(tmp_path)
    args = ["morph", *paths, "--landmarks", L, "--frames", "2", "--no-metrics", "--json"]
    assert main([*args, "-o", str(tmp_path / "c")]) == 0
    metrics = json.loads(capsys.readouterr().out)
    prep = metrics["inputs"][0]["preparation"]
    assert prep["filled_holes"] == [6] and prep["vertex_order_kept"] and prep["disk"]
    maps = json.loads((tmp_path / "c" / "preparation.json").read_text())["vertex_maps"]
    assert maps[0][:n] == list(range(n)) and set(maps[0][n:]) == {-1}
    assert metrics["files"]["preparation.json"] > 0


def test_filled_hole_centres_average_their_loops_uv_and_colour():
    # a square with a triangular hole (vertices 4, 5, 6) in the middle
    V = np.array([[0.0, 0, 0], [3, 0, 0], [3, 3, 0], [0, 3, 0], [1, 1, 0], [2, 1, 0], [1.5, 2, 0]])
    F = np.array([[0, 1, 5], [0, 5, 4], [1, 2, 5], [2, 6, 5], [2, 3, 6], [3, 4, 6], [3, 0, 4]])
    tex = np.column_stack([V[:, 0] / 3, V[:, 1] / 3])
    col = np.tile(np.arange(7.0)[:, None], (1, 3))
    V2, F2, tex2, col2 = fill_key_holes(V, F, tex, col)
    assert V2.shape == (8, 3) and len(F2) == len(F) + 3
    np.testing.assert_array_equal(V2[:7], V)  # input ids kept
    np.testing.assert_allclose(tex2[7], tex[[4, 5, 6]].mean(axis=0))
    np.testing.assert_allclose(col2[7], [5.0, 5.0, 5.0])
    np.testing.assert_array_equal(tex2[:7], tex)
    V3, F3, tex3, col3 = fill_key_holes(V, F, None, None)
    assert tex3 is None and col3 is None and V3.shape == (8, 3)
