"""Tests of ``conformorph morph2d`` without a full anchors file (issue 18)."""

import json
from pathlib import Path

import numpy as np

from conformorph.cli.main import main
from conformorph.pipelines.morph2d import DEFAULT_POINT_BUDGET

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
I_L = [str(SHAPES / "dejavu_bold_I.json"), str(SHAPES / "dejavu_bold_L.json")]


def test_no_anchors_file_chooses_them_and_writes_them_back(tmp_path, capsys):
    out = tmp_path / "auto"
    assert main(["morph2d", *I_L, "--frames", "4", "-o", str(out), "--json"]) == 0
    m = json.loads(capsys.readouterr().out)
    chosen = m["correspondence"]
    assert chosen["source"] == "automatic" and chosen["user_pairs"] == 0
    assert chosen["pairs"] >= 2 and m["outputs"]["anchors"] == "anchors.json"
    doc = json.loads((out / "anchors.json").read_text())
    assert len(doc["anchors"]) == chosen["pairs"] and doc["point_budget"] == DEFAULT_POINT_BUDGET
    assert m["working_resolution"]["point_budget"] == DEFAULT_POINT_BUDGET
    # passed back, the file is a user's full list and gives the same meshes
    again = tmp_path / "again"
    rc = main(
        ["morph2d", *I_L, "--anchors", str(out / "anchors.json"), "--frames", "4"]
        + ["-o", str(again), "--json"]
    )
    assert rc == 0
    m2 = json.loads(capsys.readouterr().out)
    assert m2["correspondence"]["source"] == "user" and "anchors" not in m2["outputs"]
    assert m2["mesh"]["vertices"] == m["mesh"]["vertices"]
    assert m2["methods"]["strain"]["total_flipped"] == m["methods"]["strain"]["total_flipped"]


def test_one_user_anchor_seeds_the_matching_and_stays_first(tmp_path, capsys):
    seed = [[188.0, 0.0], [188.0, 0.0]]
    anchors = tmp_path / "a.json"
    anchors.write_text(json.dumps({"anchors": [seed]}))
    out = tmp_path / "o"
    rc = main(
        ["morph2d", *I_L, "--anchors", str(anchors), "--frames", "3", "-o", str(out), "--json"]
    )
    assert rc == 0
    m = json.loads(capsys.readouterr().out)
    assert m["correspondence"]["source"] == "seeded" and m["correspondence"]["user_pairs"] == 1
    assert m["correspondence"]["origin"][0] == "seed"
    doc = json.loads((out / "anchors.json").read_text())
    assert doc["anchors"][0] == seed and len(doc["anchors"]) >= 2


def test_point_budget_simplifies_each_shape(tmp_path, capsys):
    heart = [str(SHAPES / "flubber_horse.json"), str(SHAPES / "flubber_heart.json")]
    rc = main(
        ["morph2d", *heart, "--point-budget", "40", "--frames", "3", "-o", str(tmp_path)]
        + ["--json"]
    )
    m = json.loads(capsys.readouterr().out)
    assert rc in (0, 1)
    res = m["working_resolution"]
    assert res["point_budget"] == 40
    assert res["source_points"][1] <= 40 < res["source_points"][0]
    assert res["target_points"][1] <= 40
    doc = json.loads((tmp_path / "anchors.json").read_text())
    src = np.array(json.loads(Path(heart[0]).read_text())["rings"][0])
    # every chosen anchor is a point of the source outline (kept by the simplification)
    for a in doc["anchors"]:
        assert np.min(np.linalg.norm(src - a[0], axis=1)) < 1e-9


def test_point_budget_out_of_range_is_exit_2(tmp_path, capsys):
    rc = main(["morph2d", *I_L, "--point-budget", "2", "-o", str(tmp_path / "o")])
    assert rc == 2 and "--point-budget must be 0 or at least 3" in capsys.readouterr().err
