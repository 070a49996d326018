"""What the viewer reads from the server before a job, and its icon (issue 31)."""

from __future__ import annotations

import argparse
from pathlib import Path

from fastapi import FastAPI
from fastapi.testclient import TestClient

from conformorph.cli import cmd_morph
from conformorph.service.errors import install_error_handlers
from conformorph.service.schemas import MorphCreate
from conformorph.service.viewer import install_viewer
from tests.service.conftest import Api


def _cli_morph_default(dest: str) -> object:
    parser = argparse.ArgumentParser()
    cmd_morph.register(parser.add_subparsers())
    sub = parser._subparsers._group_actions[0].choices["morph"]  # type: ignore[union-attr]
    return sub.get_default(dest)


def test_viewer_sends_the_clis_defaults_and_knows_the_upload_limit(api: Api) -> None:
    r = api.client.get("/viewer/config.json")
    assert r.status_code == 200, r.text
    cfg = r.json()
    assert cfg["max_upload_bytes"] == api.settings.max_upload_bytes
    defaults = cfg["morph_defaults"]
    assert defaults["prepare"] == _cli_morph_default("prepare") == "auto"
    assert defaults["vertex_budget"] == MorphCreate.model_fields["vertex_budget"].default
    assert "/viewer/config.json" not in api.client.get("/openapi.json").json()["paths"]


def test_favicon_is_served_when_built_and_a_json_404_otherwise(tmp_path: Path) -> None:
    static = tmp_path / "static"
    static.mkdir()
    app = FastAPI()
    install_error_handlers(app)
    install_viewer(app, static)
    client = TestClient(app)
    missing = client.get("/favicon.ico")
    assert missing.status_code == 404 and missing.json()["error"]["type"] == "not_found"
    (static / "favicon.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg"/>')
    r = client.get("/favicon.ico")
    assert r.status_code == 200 and r.headers["content-type"] == "image/svg+xml"
    assert r.text.startswith("<svg")
    assert (Path(__file__).resolve().parents[2] / "viewer" / "favicon.svg").is_file()
