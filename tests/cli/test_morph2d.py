"""Tests of ``conformorph morph2d``."""

import json
from pathlib import Path

import pytest

from conformorph.cli.main import main

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
        "animation.json",
        "animation.svg",
        "frames",
        "frames.json",
        "metrics.json",
        "strip.png",
        "strip.svg",
    ]
    assert len(list((tmp_path / "frames").iterdir())) == 7


def test_table_output_with_linear_interp(tmp_path, capsys):
    assert main(["morph2d", *ARGS, "--frames", "5", "--interp", "linear", "-o", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "strain" in out and "arap" in out and "linear" in out


def test_bad_input_is_one_line_exit_2(tmp_path, capsys):
    anchors = tmp_path / "a.json"
    anchors.write_text(json.dumps({"anchors": [[[0, 0], [0, 0]], [[0, 0], [1, 1]]]}))
    rc = main(["morph2d", ARGS[0], ARGS[1], "--anchors", str(anchors), "-o", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and "Traceback" not in err


def _one_line_error(capsys, rc, expect_rc=2):
    err = capsys.readouterr().err
    assert rc == expect_rc, err
    assert err.count("\n") == 1 and "Traceback" not in err
    return err


def test_max_points_and_deep_json_are_one_line_exit_2(tmp_path, capsys):
    rc = main(["morph2d", *ARGS, "--max-points", "81", "-o", str(tmp_path / "o")])
    assert "82 points; the limit is 81" in _one_line_error(capsys, rc)
    deep = tmp_path / "deep.json"
    deep.write_text('{"rings": ' + "[" * 50_000 + "]" * 50_000 + "}")
    rc = main(["morph2d", str(deep), *ARGS[1:], "-o", str(tmp_path / "o")])
    assert "nested 50001 levels deep" in _one_line_error(capsys, rc)
    svg = tmp_path / "s.svg"
    svg.write_text('<svg><path d="M0,0 L4,0 L4,1 Z 5 5"/></svg>')
    rc = main(["morph2d", str(svg), *ARGS[1:], "-o", str(tmp_path / "o")])
    assert "position 17" in _one_line_error(capsys, rc)
    assert not (tmp_path / "o").exists()


def test_default_max_points_matches_the_reader():
    from conformorph.cli.cmd_morph2d import DEFAULT_MAX_POINTS
    from conformorph.pipelines.shape_io import DEFAULT_MAX_POINTS as READER_DEFAULT

    assert DEFAULT_MAX_POINTS == READER_DEFAULT


def test_default_point_budget_matches_the_pipeline():
    from conformorph.cli.cmd_morph2d import DEFAULT_POINT_BUDGET
    from conformorph.pipelines.morph2d import DEFAULT_POINT_BUDGET as PIPELINE_DEFAULT

    assert DEFAULT_POINT_BUDGET == PIPELINE_DEFAULT


def test_non_png_texture_is_refused_before_the_solve(tmp_path, capsys):
    bad = tmp_path / "t.png"
    bad.write_bytes(b"GIF89a not a png")
    rc = main(["morph2d", *ARGS, "--texture", str(bad), "-o", str(tmp_path / "o")])
    assert "must be a PNG" in _one_line_error(capsys, rc)
    assert not (tmp_path / "o").exists()


def test_table_shows_convergence_and_the_scheme(tmp_path, capsys):
    assert main(["morph2d", *ARGS, "--frames", "5", "-o", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].split()[-2] == "converged"
    rows = {line.split()[0]: line.split() for line in lines[2:5]}
    assert rows["strain"][-2] == "yes" and rows["linear"][-2] == rows["arap"][-2] == "-"
    assert "strain scheme: principal" in lines  # the default, frame independent eq. 3


def test_a_morph_that_does_not_reach_the_target_exits_1_with_the_reason(tmp_path, capsys):
    # one Newton iteration, no continuation, no inserted steps: the bar cannot bend in one step
    caps = ["--max-iterations", "1", "--max-continuation", "1", "--max-substeps", "0"]
    caps += ["--max-time-step", "1"]
    rc = main(["morph2d", *ARGS, "--frames", "2", *caps, "-o", str(tmp_path)])
    err = _one_line_error(capsys, rc, expect_rc=1)
    assert "did not reach the target" in err and "linear stopped at frame 1 of 2" in err
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["reached_target"] is False and m["not_converged_reason"] in err
    rc = main(["morph2d", *ARGS, "--frames", "2", *caps, "-o", str(tmp_path / "j"), "--json"])
    captured = capsys.readouterr()
    assert rc == 1 and json.loads(captured.out)["reached_target"] is False
    assert captured.err.count("\n") == 1
    rc = main(["morph2d", *ARGS, "--max-iterations", "0", "-o", str(tmp_path / "x")])
    assert "--max-iterations must be at least 1" in _one_line_error(capsys, rc)
    rc = main(["morph2d", *ARGS, "--max-time-step", "0", "-o", str(tmp_path / "y")])
    assert "--max-time-step must be in (0, 1]" in _one_line_error(capsys, rc)


def test_loop_flag_and_its_default(tmp_path, capsys):
    import xml.etree.ElementTree as ET

    from conformorph.cli.main import build_parser
    from conformorph.pipelines.animation_loop import DEFAULT_LOOP

    assert build_parser().parse_args(["morph2d", "a", "b", "-o", "o"]).loop == DEFAULT_LOOP
    rc = main(
        ["morph2d", *ARGS, "--frames", "4", "--loop", "repeat", "-o", str(tmp_path), "--json"]
    )
    assert rc == 0 and json.loads(capsys.readouterr().out)["loop"] == "repeat"
    animate = (
        ET.parse(tmp_path / "animation.svg")
        .getroot()
        .find("{http://www.w3.org/2000/svg}path/{http://www.w3.org/2000/svg}animate")
    )
    assert animate is not None and animate.get("repeatCount") == "indefinite"
    with pytest.raises(SystemExit) as exc:  # argparse: usage and exit 2
        main(["morph2d", *ARGS, "--loop", "bounce", "-o", str(tmp_path / "o")])
    assert exc.value.code == 2 and "--loop" in capsys.readouterr().err
