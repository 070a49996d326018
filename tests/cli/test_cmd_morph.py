import json

import numpy as np

from cli.main import main
from tests.worker.face_fixtures import face_mesh, write_obj


def _inputs(tmp_path, reorder=False):
    paths, lms = [], []
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s)
        if reorder and i == 1:
            perm = np.random.default_rng(0).permutation(V.shape[0])
            inv = np.argsort(perm)
            V, F, lm = V[perm], inv[F], [int(inv[j]) for j in lm]
        paths.append(str(write_obj(tmp_path / f"m{i}.obj", V, F)))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    return paths, str(L)


def test_morph_json_output(tmp_path, capsys):
    paths, L = _inputs(tmp_path)
    out = tmp_path / "o"
    rc = main(
        [
            "morph",
            *paths,
            "--landmarks",
            L,
            "--frames",
            "4",
            "--times",
            "0,2",
            "-o",
            str(out),
            "--json",
        ]
    )
    assert rc == 0
    m = json.loads(capsys.readouterr().out)
    assert m["frame_times"] == [0.0, 2 / 3, 4 / 3, 2.0]
    assert (out / "animation.glb").exists() and (out / "metrics.json").exists()


def test_morph_input_errors_exit_2(tmp_path, capsys):
    paths, L = _inputs(tmp_path, reorder=True)
    out = str(tmp_path / "o")
    assert main(["morph", *paths, "--landmarks", L, "--method", "identity", "-o", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "share" in err and "Traceback" not in err
    assert main(["morph", *paths, "--landmarks", L, "--times", "0,1,2", "-o", out]) == 2
    assert "--times" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"landmarks": [[0, 1, 2], [0, 1]]}))
    assert main(["morph", *paths, "--landmarks", str(bad), "-o", out]) == 2
    assert "same number" in capsys.readouterr().err
    assert main(["morph", paths[0], "--landmarks", L, "-o", out]) == 2
