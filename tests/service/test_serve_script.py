"""``scripts/serve.sh`` keeps its state under the repository's ``./data``, as the README says.

The script is run from a copy of the repository layout whose ``.venv`` holds two
tiny stand-ins: ``python`` (the pip installs have nothing to do here) and
``conformorph``, which prints the data folder and arguments it was started with
instead of serving. ``npm`` is kept off ``PATH``, so no viewer build runs.
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _run(tmp_path: Path, *args: str, env: dict[str, str] | None = None) -> dict[str, str]:
    repo = tmp_path / "repo"
    if not repo.exists():
        (repo / "scripts").mkdir(parents=True)
        shutil.copy(ROOT / "scripts" / "serve.sh", repo / "scripts" / "serve.sh")
        venv = repo / ".venv" / "bin"
        venv.mkdir(parents=True)
        (venv / "python").write_text("#!/bin/sh\nexit 0\n")
        (venv / "conformorph").write_text(
            '#!/bin/sh\necho "DATA=${CONFORMORPH_DATA_DIR:-unset}"\necho "ARGS=$*"\n'
        )
        tools = tmp_path / "tools"
        tools.mkdir()
        dirname = shutil.which("dirname")
        assert dirname is not None
        os.symlink(dirname, tools / "dirname")
        for f in (venv / "python", venv / "conformorph"):
            f.chmod(f.stat().st_mode | stat.S_IXUSR)
    bash = shutil.which("bash")
    if bash is None:
        pytest.skip("bash not installed")
    out = subprocess.run(
        [bash, str(repo / "scripts" / "serve.sh"), *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={"PATH": str(tmp_path / "tools"), "HOME": str(tmp_path), **(env or {})},
        timeout=60,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    return dict(line.split("=", 1) for line in out.stdout.splitlines() if "=" in line)


def test_serve_sh_defaults_to_the_repositorys_data_folder(tmp_path: Path) -> None:
    got = _run(tmp_path)
    assert Path(got["DATA"]).resolve() == (tmp_path / "repo" / "data").resolve()
    assert got["ARGS"] == "serve"


def test_serve_sh_keeps_the_callers_choice(tmp_path: Path) -> None:
    chosen = str(tmp_path / "elsewhere")
    assert _run(tmp_path, env={"CONFORMORPH_DATA_DIR": chosen})["DATA"] == chosen
    # --data-dir is passed on: ``conformorph serve`` lets it win over the variable
    got = _run(tmp_path, "--port", "8001", "--data-dir", chosen)
    assert got["ARGS"] == f"serve --port 8001 --data-dir {chosen}"


def test_the_data_folder_is_not_committed() -> None:
    git = shutil.which("git")
    if git is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    r = subprocess.run([git, "check-ignore", "-q", "data/jobs.sqlite"], cwd=ROOT)
    assert r.returncode == 0, "./data is not in .gitignore"


def test_serve_sh_installs_only_when_the_requirements_change(tmp_path: Path) -> None:
    """A second start with nothing changed runs no pip (issue 31: 15 s to ready before)."""
    repo = tmp_path / "repo"
    (repo / "scripts").mkdir(parents=True)
    (repo / "conformorph_client").mkdir()
    for name in ("scripts/serve.sh", "scripts/install_landmarks.sh", "pyproject.toml",
                 "setup.py", "conformorph_client/pyproject.toml"):
        shutil.copy(ROOT / name, repo / name)
    venv = repo / ".venv" / "bin"
    venv.mkdir(parents=True)
    calls = tmp_path / "python-calls"
    (venv / "python").write_text(f'#!/bin/sh\necho "$*" >> {calls}\nexit 0\n')
    (venv / "conformorph").write_text('#!/bin/sh\necho "ARGS=$*"\n')
    for f in (venv / "python", venv / "conformorph"):
        f.chmod(f.stat().st_mode | stat.S_IXUSR)
    tools = tmp_path / "tools"
    tools.mkdir()
    for tool in ("dirname", "sha256sum", "cut", "cat", "bash"):
        found = shutil.which(tool)
        if found is None:
            pytest.skip(f"{tool} not installed")
        os.symlink(found, tools / tool)

    def start() -> list[str]:
        calls.unlink(missing_ok=True)
        out = subprocess.run(
            [str(tools / "bash"), str(repo / "scripts" / "serve.sh")],
            capture_output=True, text=True, cwd=tmp_path, timeout=60,
            env={"PATH": str(tools), "HOME": str(tmp_path)},
        )
        assert out.returncode == 0 and "ARGS=serve" in out.stdout, out.stdout + out.stderr
        return calls.read_text().splitlines() if calls.exists() else []

    first = start()
    assert any("pip install" in c and "-e ." in c for c in first), first
    assert start() == []  # nothing changed: straight to serving
    with (repo / "pyproject.toml").open("a") as f:
        f.write("\n# a changed requirement\n")
    assert any("pip install" in c for c in start())
    assert start() == []
