import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.cli.main import main
from tests.pipelines.face_fixtures import face_mesh, write_obj


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


def test_morph_frame_times_extrapolate_outside_the_keys(tmp_path, capsys):
    import pygltflib
    import pytest

    from tests.pipelines.test_export_gltf import read_accessor

    paths, L = _inputs(tmp_path)
    out = tmp_path / "o"
    args = ["morph", *paths, "--landmarks", L, "--no-metrics", "-o", str(out), "--json"]
    # a list starting with a minus sign is passed with "=" (argparse reads "-0.5" as an option)
    assert main([*args, "--frame-times=-0.5,0,0.5,1,1.5"]) == 0
    m = json.loads(capsys.readouterr().out)
    assert m["frame_times"] == [-0.5, 0.0, 0.5, 1.0, 1.5]
    gl = pygltflib.GLTF2().load(str(out / "animation.glb"))
    prim = gl.meshes[0].primitives[0]
    assert gl.meshes[0].extras["targetNames"][0] == "t=-0.5"
    base = read_accessor(gl, prim.attributes.POSITION)
    P = np.stack([base + read_accessor(gl, t["POSITION"]) for t in prim.targets])
    # two keys: the homotopy is close to linear in t, and outside [0, 1] it goes on
    # (extrapolates) instead of stopping at the keys
    step = np.linalg.norm(P[1:] - P[:-1], axis=2).mean(axis=1)
    assert step.min() > 0.5 * step.max()
    with pytest.raises(SystemExit) as exc:  # --frames and --frame-times exclude each other
        main([*args, "--frames", "4", "--frame-times", "0,1"])
    assert exc.value.code == 2 and "not allowed with" in capsys.readouterr().err
    assert main([*args, "--frame-times", "0,1,1"]) == 2
    err = capsys.readouterr().err
    assert "strictly increasing" in err and err.count("\n") == 1


def test_morph_reports_folds_and_dmt_fallbacks(tmp_path, capsys):
    paths, L = _inputs(tmp_path)
    out = str(tmp_path / "o")
    base = ["morph", *paths, "--no-metrics", "--frames", "2", "-o", out]
    assert main([*base, "--landmarks", L]) == 0
    cap = capsys.readouterr()
    assert "0 folded triangles, min Jacobian" in cap.out and "fallback" not in cap.out
    assert cap.err == ""
    # the left eye and brow swapped on mesh 1: matching them exactly would fold the
    # disk, DMT falls back to a smoothed fit; the user is told, on stderr
    lms = json.loads(open(L).read())["landmarks"]
    lms[1][0], lms[1][6] = lms[1][6], lms[1][0]
    swapped = tmp_path / "swapped.json"
    swapped.write_text(json.dumps({"landmarks": lms}))
    assert main([*base, "--landmarks", str(swapped), "--json"]) == 0
    cap = capsys.readouterr()
    m = json.loads(cap.out)
    assert m["bijectivity"]["folded_triangles"] == 0
    assert m["bijectivity"]["fallbacks"][0]["fallback"] == "regularized"
    assert "warning: meshes 0 -> 1: DMT would fold" in cap.err
    assert (
        json.loads((tmp_path / "o" / "metrics.json").read_text())["bijectivity"] == m["bijectivity"]
    )


SHARED = Path(__file__).resolve().parents[3] / "shared" / "data" / "faces"


@pytest.mark.shared_data
@pytest.mark.skipif(
    not (SHARED / "meshmonk_landmarks.json").exists(), reason="../shared/data absent"
)
def test_morph_meshmonk_faces_not_prealigned(tmp_path, capsys):
    # MeshMonk's simulated faces: 5 landmarks (eye corners, nose tip, mouth corners), boundary
    # ear triangles, and not rigidly aligned (SIMPOP_01 and _09 lie 145 mm apart on average)
    from conformorph.pipelines.mesh_io import read_mesh

    a, b = SHARED / "meshmonk_SIMPOP_01.obj", SHARED / "meshmonk_SIMPOP_09.obj"
    L = SHARED / "meshmonk_landmarks.json"
    lm = json.loads(L.read_text())["nearest_vertex_0based"]
    Va, _ = read_mesh(a)
    Vb, _ = read_mesh(b)
    assert np.linalg.norm(Va[lm] - Vb[lm], axis=1).mean() > 100.0  # mm, before alignment
    out = tmp_path / "o"
    args = ["morph", str(a), str(b), "--landmarks", str(L), "--frames", "3", "-o", str(out)]
    # as read (--prepare none), the ear triangles: a one-line error naming them
    assert main([*args, "--prepare", "none", "--json"]) == 2
    assert "ear" in capsys.readouterr().err
    assert main([*args, "--prepare", "none", "--remove-ears", "--json"]) == 0
    m = json.loads(capsys.readouterr().out)
    assert m["bijectivity"]["folded_triangles"] == 0 and m["bijectivity"]["fallbacks"] == []
    (pair,) = m["registration"]["pairs"]
    assert pair["folded_triangles"] == {"mt": 0, "dmt": 0}
    # the default (refine auto: nicp here) fits the dense correspondences with Tikhonov
    # smoothing: the landmarks are met to ~1e-5 (measured 2.4e-5), not exactly
    assert pair["nicp"]["correspondences"] > 0
    assert pair["E_D"]["dmt"] < 1e-4 and 100 * pair["E_D"]["dmt"] < pair["E_D"]["mt"]
    (rigid,) = m["registration"]["rigid_alignment"]
    # residuals in diameters (~183 mm): measured 0.012 at the landmarks, ICP 0.008
    assert 0 < rigid["rms_all"] < 0.03 and 0 < rigid["icp_rms"] < 0.02
    assert rigid["n_rigid_landmarks"] >= 3
    assert max(m["frames"]["key_frame_L2_to_inputs"]["dmt"]) < 5e-3
    assert (out / "animation.glb").stat().st_size > 0


def test_landmark_fit_flag_maps_to_the_registration(tmp_path, capsys):
    from conformorph.cli.cmd_morph import morph_options_from_args
    from conformorph.cli.main import build_parser
    from conformorph.worker.stages.face_morph import morph_options_from_params

    args = build_parser().parse_args(
        ["morph", "a.obj", "b.obj", "--landmarks", "l.json", "-o", "o"]
    )
    assert morph_options_from_args(args).registration.landmark_fit == "exact"
    args = build_parser().parse_args(
        [
            "morph",
            "a.obj",
            "b.obj",
            "--landmarks",
            "l.json",
            "-o",
            "o",
            "--landmark-fit",
            "tolerant",
        ]
    )
    assert morph_options_from_args(args).registration.landmark_fit == "tolerant"
    assert morph_options_from_params({}).registration.landmark_fit == "exact"
    # 'auto' (the default): tolerant for detected landmarks, exact for given ones
    auto = build_parser().parse_args(["morph", "a.obj", "b.obj", "--landmarks", "auto", "-o", "o"])
    assert morph_options_from_args(auto).registration.landmark_fit == "tolerant"
    auto_exact = build_parser().parse_args(
        ["morph", "a.obj", "b.obj", "--landmarks", "auto", "-o", "o", "--landmark-fit", "exact"]
    )
    assert morph_options_from_args(auto_exact).registration.landmark_fit == "exact"
    assert morph_options_from_params({"landmarks": "auto"}).registration.landmark_fit == (
        "tolerant"
    )
    detected_exact = {"landmarks": "auto", "landmark_fit": "exact"}
    assert morph_options_from_params(detected_exact).registration.landmark_fit == "exact"
    assert morph_options_from_params({"landmark_fit": "tolerant"}).registration.landmark_fit == (
        "tolerant"
    )
    paths, L = _inputs(tmp_path)
    out = tmp_path / "o"
    rc = main(["morph", *paths, "--landmarks", L, "--frames", "3", "-o", str(out), "--json"])
    assert rc == 0 and not (out / "landmarks_corrected.json").exists()
    capsys.readouterr()
    rc = main(
        [
            "morph",
            *paths,
            "--landmarks",
            L,
            "--frames",
            "3",
            "--landmark-fit",
            "tolerant",
            "-o",
            str(out),
            "--json",
        ]
    )
    assert rc == 0
    assert json.loads(capsys.readouterr().out)["registration"]["landmark_fit"] == "tolerant"
    assert (out / "landmarks_corrected.json").exists()
    with pytest.raises(SystemExit):
        build_parser().parse_args(
            ["morph", "a", "b", "--landmarks", "l", "-o", "o", "--landmark-fit", "loose"]
        )


def test_morph_cache_flags(tmp_path, capsys):
    import os

    paths, L = _inputs(tmp_path)
    base = ["morph", *paths, "--landmarks", L, "--frames", "3", "--json", "-o"]
    cache = tmp_path / "keys"
    assert main([*base, str(tmp_path / "a"), "--cache", str(cache)]) == 0
    first = json.loads(capsys.readouterr().out)
    assert [m["cache"]["state"] for m in first["inputs"]] == ["stored", "stored"]
    assert len(list(cache.glob("*.npz"))) == 2
    assert main([*base, str(tmp_path / "b"), "--cache", str(cache)]) == 0
    again = json.loads(capsys.readouterr().out)
    assert [m["cache"]["state"] for m in again["inputs"]] == ["hit", "hit"]
    assert again["frames"]["key_frame_L2_to_inputs"] == first["frames"]["key_frame_L2_to_inputs"]
    assert again["bijectivity"] == first["bijectivity"]
    # the default folder: $XDG_CACHE_HOME/conformorph (the tests' own, see conftest)
    default = Path(os.environ["XDG_CACHE_HOME"]) / "conformorph"
    assert main([*base, str(tmp_path / "c")]) == 0
    capsys.readouterr()
    assert len(list(default.glob("*.npz"))) == 2
    # --no-cache: nothing looked up or stored
    assert main([*base, str(tmp_path / "d"), "--no-cache"]) == 0
    none = json.loads(capsys.readouterr().out)
    assert all("cache" not in m for m in none["inputs"]) and len(list(default.glob("*"))) == 2
    with pytest.raises(SystemExit):
        main([*base, str(tmp_path / "e"), "--no-cache", "--cache", str(cache)])


def test_units_and_normals_flags(tmp_path, capsys):
    import pygltflib

    paths, L = _inputs(tmp_path)
    V, F, _ = face_mesh(1.0)
    big = str(write_obj(tmp_path / "m1_x10.obj", 10.0 * V, F))
    out = tmp_path / "o"
    args = ["morph", paths[0], big, "--landmarks", L, "--frames", "2", "--no-metrics"]
    # declared: one unit for both, and the second is 10x the first
    assert main([*args, "--units", "cm", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "sizes disagree" in err and "--units" in err
    with pytest.raises(SystemExit) as exc:  # argparse's own exit 2
        main([*args, "--units", "furlong", "-o", str(out)])
    assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err
    # declared in metres, no normal targets
    argv = ["morph", *paths, "--landmarks", L, "--frames", "2", "--no-metrics", "--json"]
    assert main([*argv, "--units", "m", "--no-normals", "-o", str(out)]) == 0
    m = json.loads(capsys.readouterr().out)
    assert [(k["units"], k["source"]) for k in m["units"]["keys"]] == [("m", "declared")] * 2
    gl = pygltflib.GLTF2().load(str(out / "animation.glb"))
    assert all(t.get("NORMAL") is None for t in gl.meshes[0].primitives[0].targets)
    assert main([*argv, "--units", "mm", "--normals", "-o", str(out)]) == 0  # kept accepted
    capsys.readouterr()
    gl = pygltflib.GLTF2().load(str(out / "animation.glb"))
    assert all(t.get("NORMAL") is not None for t in gl.meshes[0].primitives[0].targets)
    assert gl.nodes[0].extras["metres_per_input_unit"] == 0.001
