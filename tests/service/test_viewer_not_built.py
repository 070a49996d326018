"""A server whose viewer is not built says how to build it, at ``/`` and when it starts."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from conformorph.service.errors import install_error_handlers
from conformorph.service.viewer import BUILD_HINT, install_viewer


def _app(static_dir: Path) -> TestClient:
    app = FastAPI()
    install_error_handlers(app)
    install_viewer(app, static_dir)
    return TestClient(app)


def test_root_says_how_to_build_it(tmp_path: Path) -> None:
    client = _app(tmp_path / "static")
    r = client.get("/", headers={"accept": "application/json"})
    assert r.status_code == 404
    assert r.json()["error"]["type"] == "viewer_not_built"
    assert "npm install && npm run build:viewer" in r.json()["error"]["message"]
    page = client.get("/", headers={"accept": "text/html,application/xhtml+xml,*/*;q=0.8"})
    assert page.status_code == 404 and page.headers["content-type"].startswith("text/html")
    assert "npm install &amp;&amp; npm run build:viewer" in page.text
    assert "pip install ." in page.text


def test_a_build_is_served(tmp_path: Path) -> None:
    static = tmp_path / "static"
    static.mkdir()
    (static / "index.html").write_text("<!doctype html><title>viewer</title>")
    client = _app(static)
    r = client.get("/", headers={"accept": "text/html"})
    assert r.status_code == 200 and "<title>viewer</title>" in r.text


def test_start_up_logs_how_to_build_it(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="conformorph.service.viewer"):
        _app(tmp_path / "static")
    assert any(BUILD_HINT in r.getMessage() for r in caplog.records)
    caplog.clear()
    static = tmp_path / "built"
    static.mkdir()
    (static / "index.html").write_text("x")
    with caplog.at_level(logging.WARNING, logger="conformorph.service.viewer"):
        _app(static)
    assert not caplog.records


def test_the_warning_reaches_stderr_without_logging_set_up(tmp_path: Path) -> None:
    """``conformorph serve`` configures no root handler: the warning still shows."""
    code = (
        "import sys; from pathlib import Path; from fastapi import FastAPI;"
        "from conformorph.service.viewer import install_viewer;"
        "install_viewer(FastAPI(), Path(sys.argv[1]))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "none")],
        capture_output=True,
        text=True,
        cwd=Path(__file__).parents[2],
        check=True,
    )
    assert "npm install && npm run build:viewer" in out.stderr
