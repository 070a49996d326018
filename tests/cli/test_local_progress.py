"""Progress bars of the local commands: on a terminal's stderr, off with --quiet or off a terminal."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

from conformorph.cli.main import main
from conformorph.pipelines.mesh_io import write_obj
from tests.meshes import bumpy_disk

from ..pipelines.face_fixtures import face_mesh
from ..pipelines.face_fixtures import write_obj as write_face

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"


class _Terminal(io.StringIO):
    """A stderr that says it is a terminal (rich then draws its bar into it)."""

    def isatty(self) -> bool:
        return True


def _run(monkeypatch: pytest.MonkeyPatch, argv: list[str], tty: bool) -> tuple[int, str]:
    err = _Terminal() if tty else io.StringIO()
    monkeypatch.setattr("sys.stderr", err)
    code = main(argv)
    return code, err.getvalue()


@pytest.fixture
def mesh(tmp_path: Path) -> Path:
    V, F = bumpy_disk(6)
    write_obj(tmp_path / "m.obj", V, F)
    return tmp_path / "m.obj"


def test_map_and_reconstruct_bars(monkeypatch: pytest.MonkeyPatch, tmp_path: Path, mesh: Path) -> None:
    for cmd, out in (("map", "m.npz"), ("reconstruct", "r.obj")):
        argv = [cmd, str(mesh), "-o", str(tmp_path / out)]
        code, err = _run(monkeypatch, argv, tty=True)
        assert code == 0 and cmd in err and "100%" in err, err
        code, err = _run(monkeypatch, [*argv, "--quiet"], tty=True)
        assert code == 0 and err == ""
        code, err = _run(monkeypatch, argv, tty=False)
        assert code == 0 and err == ""


def test_morph_bar_shows_the_stages(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    paths, lms = [], []
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s, levels=2)
        paths.append(str(write_face(tmp_path / f"f{i}.obj", V, F)))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    argv = ["morph", *paths, "--landmarks", str(L), "--frames", "3", "-o", str(tmp_path / "o")]
    code, err = _run(monkeypatch, [*argv, "--no-metrics"], tty=True)
    assert code == 0 and "morph" in err and "100%" in err, err
    code, err = _run(monkeypatch, [*argv, "--no-metrics", "--quiet"], tty=True)
    assert code == 0 and err == ""


def test_morph2d_bar(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    argv = [
        "morph2d",
        str(SHAPES / "bar_straight.json"),
        str(SHAPES / "bar_bent.json"),
        "--anchors",
        str(SHAPES / "bar_anchors.json"),
        "--frames",
        "5",
        "-o",
        str(tmp_path / "o"),
    ]
    code, err = _run(monkeypatch, argv, tty=True)
    assert code == 0 and "morph2d" in err and "100%" in err, err
    code, err = _run(monkeypatch, [*argv, "--quiet"], tty=False)
    assert code == 0 and err == ""
