"""An npm package that a test needs, at the version package.json pins, or a skip saying why.

Looked for in the repository's ``node_modules`` first (``npm install`` puts the
devDependencies there); when it is missing or at another version, installed by
npm into a temporary folder of the test session (never the repository's).
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.live_server import ROOT


def npm_package(name: str, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder of npm package ``name`` (a devDependency of package.json).

    Skips the test when neither ``node_modules`` has it nor npm can install it.
    """
    version = json.loads((ROOT / "package.json").read_text())["devDependencies"][name]
    local = ROOT / "node_modules" / name
    manifest = local / "package.json"
    if manifest.is_file() and json.loads(manifest.read_text()).get("version") == version:
        return local
    npm = shutil.which("npm")
    if npm is None:
        pytest.skip(f"{name} is not in node_modules and npm is missing to install it")
    prefix = tmp_path_factory.mktemp("npm")
    done = subprocess.run(
        [npm, "install", "--no-save", "--no-package-lock", "--no-audit", "--no-fund"]
        + ["--prefix", str(prefix), f"{name}@{version}"],
        capture_output=True,
        text=True,
        timeout=240,
    )
    folder = prefix / "node_modules" / name
    if done.returncode != 0 or not (folder / "package.json").is_file():
        pytest.skip(f"npm could not install {name}@{version}: {done.stderr.strip()[-300:]}")
    return folder
