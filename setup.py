"""Packaging of the server distribution ``conformorph`` (metadata: pyproject.toml).

Two things pyproject.toml cannot say:

* **Install names.** The repository's top-level folders (geometry/, pipelines/,
  worker/, service/, cli/) install as ``conformorph.geometry`` and so on (setuptools'
  package-dir mapping), so site-packages gets one top-level package, ``conformorph``
  (``conformorph/__init__.py``), beside the REST client package ``conformorph_client``
  that ``conformorph submit`` and ``batch`` import. The client is also its own,
  lighter distribution (``conformorph_client/pyproject.toml``: httpx and pydantic
  only); the server carries the same package rather than depending on that
  distribution, which is on no index, so ``pip install .`` (or ``pip install
  git+URL``) of the server alone resolves in a fresh venv. Installing both
  (``pip install ./conformorph_client .``) writes the same files twice, harmlessly.
* **The browser viewer in the wheel and the sdist.** ``service/static/`` is built by
  npm from ``viewer/``; a non-editable build runs ``npm install`` and
  ``npm run build:viewer`` when it is missing, and stops with a message saying what to
  install when npm is not there. ``CONFORMORPH_BUILD_VIEWER=0`` builds without it (the
  server then says at ``/`` and in its log how to build it).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from setuptools import find_packages, setup
from setuptools.command.build_py import build_py
from setuptools.command.sdist import sdist

HERE = Path(__file__).resolve().parent
FOLDERS = ("geometry", "pipelines", "worker", "service", "cli")
STATIC = HERE / "service" / "static"
VIEWER_HELP = (
    "the browser viewer (service/static/) is built by npm from viewer/: install Node.js "
    "and npm (https://nodejs.org) and build again, or run 'npm install && npm run "
    "build:viewer' first; CONFORMORPH_BUILD_VIEWER=0 builds a wheel without the viewer"
)


def _packages() -> tuple[list[str], dict[str, str]]:
    """Every package under its install name, and the folder each top-level one maps to
    (the client's folder is its own package, as in its own distribution)."""
    found = find_packages(where=str(HERE), include=[f"{f}" for f in FOLDERS] + [f"{f}.*" for f in FOLDERS])
    return ["conformorph", *(f"conformorph.{p}" for p in found), "conformorph_client"], {
        "conformorph": "conformorph",
        **{f"conformorph.{f}": f for f in FOLDERS},
        "conformorph_client": "conformorph_client",
    }


def build_viewer() -> None:
    """Build service/static/ with npm when it is missing (and wanted)."""
    if (STATIC / "index.html").is_file() or os.environ.get("CONFORMORPH_BUILD_VIEWER") == "0":
        return
    npm = shutil.which("npm")
    if npm is None or not (HERE / "package.json").is_file():
        raise SystemExit(f"error: npm not found: {VIEWER_HELP}")
    for cmd in (
        [npm, "install", "--no-audit", "--no-fund", "--loglevel=error"],
        [npm, "run", "--silent", "build:viewer"],
    ):
        if subprocess.run(cmd, cwd=HERE).returncode != 0:
            raise SystemExit(f"error: {' '.join(cmd[1:])} failed: {VIEWER_HELP}")
    if not (STATIC / "index.html").is_file():
        raise SystemExit(f"error: npm run build:viewer wrote no service/static/index.html: {VIEWER_HELP}")


class BuildPyWithViewer(build_py):
    """build_py that builds the viewer first (not for editable installs, which serve the
    checkout's service/static/ as the set-up scripts build it)."""

    def run(self) -> None:
        if not getattr(self, "editable_mode", False):
            build_viewer()
            self.data_files = self._get_data_files()  # computed before the build: again
        super().run()


class SdistWithViewer(sdist):
    """sdist that carries the built viewer, so a wheel built from it needs no npm."""

    def run(self) -> None:
        build_viewer()
        super().run()


PACKAGES, PACKAGE_DIR = _packages()
setup(
    packages=PACKAGES,
    package_dir=PACKAGE_DIR,
    cmdclass={"build_py": BuildPyWithViewer, "sdist": SdistWithViewer},
)
