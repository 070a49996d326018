"""The committed ``openapi/openapi.json`` matches the app (regenerate: ``conformorph openapi``)."""

from __future__ import annotations

import json
from pathlib import Path

from conformorph.cli.cmd_openapi import openapi_text

COMMITTED = Path(__file__).resolve().parents[2] / "openapi" / "openapi.json"


def test_committed_openapi_has_not_drifted() -> None:
    current = openapi_text()
    assert COMMITTED.read_text(encoding="utf-8") == current, (
        "openapi/openapi.json is stale: run 'conformorph openapi' and commit the result"
    )


def test_openapi_documents_every_route_and_json_errors() -> None:
    doc = json.loads(openapi_text())
    paths = doc["paths"]
    for p in (
        "/v1/meshes",
        "/v1/textures",
        "/v1/conformal-maps",
        "/v1/reconstructions",
        "/v1/jobs",
        "/v1/jobs/{job_id}",
        "/v1/jobs/{job_id}/events",
        "/v1/jobs/{job_id}/artifacts/{name}",
        "/healthz",
        "/readyz",
    ):
        assert p in paths, p
    ops = [op for item in paths.values() for op in item.values()]
    assert len({op["operationId"] for op in ops}) == len(ops)
    assert paths["/v1/conformal-maps"]["post"]["responses"]["422"]["content"]["application/json"][
        "schema"
    ]["$ref"].endswith("/ErrorBody")
