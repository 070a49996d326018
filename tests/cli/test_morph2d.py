"""Tests of ``conformorph morph2d``."""

import json
from pathlib import Path

from cli.main import main

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
ARGS = [
    str(SHAPES / "bar_straight.json"),
    str(SHAPES / "bar_bent.json"),
    "--anchors",
    str(SHAPES / "bar_anchors.json"),
]


def test_json_output_and_files(tmp_path, capsys):
    rc = main(["morph2d", *ARGS, "--frames", "7", "--per-frame", "-o", str(tmp_path), "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["frames"] == 7 and out["methods"]["strain"]["total_flipped"] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "animation.glb",
        "frames",
        "metrics.json",
        "strip.svg",
    ]
    assert len(list((tmp_path / "frames").iterdir())) == 7


def test_table_output_with_linear_interp(tmp_path, capsys):
    assert main(["morph2d", *ARGS, "--frames", "5", "--interp", "linear", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "strain" in out and "arap" in out and "linear" in out


def test_bad_input_is_one_line_exit_2(tmp_path, capsys):
    anchors = tmp_path / "a.json"
    anchors.write_text(json.dumps({"anchors": [[[0, 0], [0, 0]]]}))
    rc = main(["morph2d", ARGS[0], ARGS[1], "--anchors", str(anchors), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and "at least 2" in err and "Traceback" not in err
