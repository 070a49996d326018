"""Issue 30, item 7, on the command line: ``conformorph morph``, ``submit`` and batch
manifests refuse the values the API refuses (the same ranges, conformorph.pipelines.job_fields),
with exit code 2 and a message naming the entry, before any work or upload."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from conformorph.cli.cmd_batch import load_manifest
from conformorph.cli.main import main
from tests.live_server import small_face_pair

CASES = [
    (["--times", "0,1e308"], "times[1]"),
    (["--times", "0,1e-320"], "times"),
    (["--frame-times=-1e6,1e6"], "frame_times[0]"),
    (["--frame-times", "0,1e308"], "frame_times[1]"),
]


@pytest.mark.parametrize(("flags", "where"), CASES)
def test_morph_and_submit_exit_2_naming_the_entry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], flags: list[str], where: str
) -> None:
    a, b, lm = small_face_pair(tmp_path / "in")
    for cmd in (["morph"], ["submit", "--server", "http://127.0.0.1:9"]):
        rc = main([*cmd, str(a), str(b), "--landmarks", str(lm), *flags, "-o", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert rc == 2 and where in err and err.count("\n") == 1, (cmd, err)
        assert not (tmp_path / "o" / "animation.glb").exists()


@pytest.mark.parametrize(("flags", "where"), CASES)
def test_batch_manifest_refuses_the_same_values(
    tmp_path: Path, flags: list[str], where: str
) -> None:
    small_face_pair(tmp_path)
    key, value = (
        flags[-1].lstrip("-").split("=", 1) if "=" in flags[-1] else (flags[0][2:], flags[1])
    )
    job = {
        "name": "j",
        "meshes": ["face_a.obj", "face_b.obj"],
        "landmarks": "landmarks.json",
        key.replace("-", "_"): [float(t) for t in value.split(",")],
    }
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"jobs": [job]}))
    with pytest.raises(ValueError, match=r"jobs\[0\]") as info:
        load_manifest(path)
    assert where in str(info.value)
    job[key.replace("-", "_")] = [0, 1]
    path.write_text(json.dumps({"jobs": [job]}))
    assert load_manifest(path)[0].params[key.replace("-", "_")] == [0, 1]
