"""Shared fixtures of the browser tests: Debian's chromium driven by Playwright.

Skips (saying why) when chromium is not installed at /usr/bin/chromium or
Playwright for Python is missing; the test command installs both. The viewer
is built from ``viewer/`` (``npm run build:viewer``) when ``service/static``
has no build yet.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.live_server import ROOT

CHROMIUM = Path("/usr/bin/chromium")
STATIC = ROOT / "service" / "static"
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


@pytest.fixture(scope="module")
def built() -> Path:
    if not (STATIC / "index.html").is_file() or not (STATIC / "viewer.js").is_file():
        npm = shutil.which("npm")
        if npm is None or not (ROOT / "node_modules" / "three").is_dir():
            pytest.skip("viewer not built and no npm/three to build it: run 'npm install'")
        subprocess.run([npm, "run", "build:viewer"], cwd=ROOT, check=True, capture_output=True)
    return STATIC


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    if not CHROMIUM.exists():
        pytest.skip(
            "Debian's chromium is not installed at /usr/bin/chromium "
            "(the test command installs it with apt-get; it could not here)"
        )
    sync_api = pytest.importorskip(
        "playwright.sync_api", reason="Playwright for Python is not installed"
    )
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=FLAGS)
        try:
            yield b
        finally:
            b.close()


@pytest.fixture
def page(browser: Any) -> Iterator[Any]:
    context = browser.new_context(viewport={"width": 1280, "height": 800})
    pg = context.new_page()
    errors: list[str] = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.errors = errors
    # console errors (a failed resource such as a favicon 404 is one): a test that walks
    # a person's path asserts there are none; tests of refused requests expect some
    console: list[str] = []
    pg.on("console", lambda m: console.append(f"{m.text} @ {m.location}") if m.type == "error" else None)
    pg.console_errors = console
    try:
        yield pg
    finally:
        context.close()
    assert not errors, errors
