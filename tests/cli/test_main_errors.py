"""``conformorph``'s error policy: input problems are one line and exit 2; bugs stay loud."""

import pytest

import conformorph.cli.cmd_map  # noqa: F401 - loads conformorph.cli.cmd_map
from conformorph import cli
from conformorph.cli.main import main
from tests.meshes import FIXTURES


def _one_line(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err


def test_too_deeply_nested_json_is_an_input_error(tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)  # json raises RecursionError on this
    mesh = str(FIXTURES / "service_small_face.obj")
    rc = main(["morph", mesh, mesh, "--landmarks", str(deep), "-o", str(tmp_path / "o")])
    assert rc == 2
    _one_line(capsys, "conformorph morph: error:", "too deeply nested", "RecursionError")


def test_memory_error_is_an_input_error_and_other_errors_stay_loud(tmp_path, capsys, monkeypatch):
    args = ["map", str(FIXTURES / "service_small_face.obj"), "-o", str(tmp_path / "m.npz")]

    def too_big(_args):
        raise MemoryError("Unable to allocate 80.0 GiB for an array")

    monkeypatch.setattr(cli.cmd_map, "run_map", too_big)
    assert main(args) == 2
    _one_line(capsys, "conformorph map: error:", "too large", "Unable to allocate 80.0 GiB")

    def bug(_args):
        raise TypeError("a programming error")

    monkeypatch.setattr(cli.cmd_map, "run_map", bug)
    with pytest.raises(TypeError, match="a programming error"):
        main(args)
