"""``conformorph COMMAND`` registers only COMMAND's module (cli/main.py COMMAND_OWNERS)."""

import argparse
import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from conformorph.cli.main import COMMAND_MODULES, COMMAND_OWNERS, build_parser, main
from tests.pipelines.face_fixtures import face_mesh, write_obj

ROOT = Path(__file__).resolve().parents[2]


def _commands(parser: argparse.ArgumentParser) -> set[str]:
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return set(sub.choices)


def _registered_by(module: str) -> set[str]:
    p = argparse.ArgumentParser()
    sub = p.add_subparsers()
    importlib.import_module(module).register(sub)
    return _commands(p)


def test_owners_are_what_each_module_registers():
    by_module: dict[str, set[str]] = {}
    for command, module in COMMAND_OWNERS.items():
        by_module.setdefault(module, set()).add(command)
    assert sorted(by_module) == sorted(COMMAND_MODULES)
    for module, commands in by_module.items():
        assert _registered_by(module) == commands, module


@pytest.mark.parametrize("command", [None, "--help", "morhp"])
def test_anything_but_a_command_gets_every_command(command):
    assert _commands(build_parser(command)) == set(COMMAND_OWNERS)


def test_a_command_gets_its_own_module_only():
    assert _commands(build_parser("morph")) == {"morph"}
    assert _commands(build_parser("reconstruct")) == {"map", "reconstruct"}


def test_a_misspelt_command_is_exit_2_naming_the_choices(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["morhp"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'morhp'" in err and "morph2d" in err


def test_morph_imports_no_service_worker_or_detection_modules(tmp_path):
    paths, lms = [], []
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s, levels=2)
        paths.append(str(write_obj(tmp_path / f"m{i}.obj", V, F)))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    code = (
        "import sys\nfrom conformorph.cli.main import main\n"
        f"rc = main(['morph', *{paths!r}, '--landmarks', {str(L)!r}, '--frames', '3', "
        f"'-o', {str(tmp_path / 'o')!r}, '-q'])\n"
        "heavy = ('fastapi', 'starlette', 'celery', 'kombu', 'sqlalchemy', 'pydantic', "
        "'mediapipe', 'httpx', 'conformorph.service', 'conformorph.worker', 'uvicorn')\n"
        "names = {m.split('.')[0] for m in sys.modules} | {'.'.join(m.split('.')[:2]) for m in sys.modules}\n"
        "print(rc, sorted(names & set(heavy)))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip().splitlines()[-1] == "0 []"
    assert (tmp_path / "o" / "animation.glb").is_file()
