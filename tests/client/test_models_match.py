"""The client's models (its own copy, so that it installs alone) are the server's.

``conformorph_client/_schemas.py`` is written by ``tools/sync_client_models.py``
from the server's ``service/schemas.py``. These tests hold it to that module's
text and each model's JSON schema to the component of ``openapi/openapi.json``
(the published contract), in validation and serialization mode alike.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from pydantic import BaseModel, Field

from conformorph_client import _schemas, models

ROOT = Path(__file__).resolve().parents[2]
OPENAPI = ROOT / "openapi" / "openapi.json"
#: components FastAPI writes itself (form bodies, its 422 body): not API models
FASTAPI_OWN = ("Body_", "HTTPValidationError", "ValidationError")
SYNC_HINT = "run: python tools/sync_client_models.py (and conformorph openapi)"


def _sync_tool() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "sync_client_models", ROOT / "tools" / "sync_client_models.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _normalised(schema: Any) -> Any:
    """``schema`` without ``"default": null`` entries, which FastAPI's document omits."""
    if isinstance(schema, dict):
        return {
            k: _normalised(v) for k, v in schema.items() if not (k == "default" and v is None)
        }
    if isinstance(schema, list):
        return [_normalised(v) for v in schema]
    return schema


def schema_mismatches(model: type[BaseModel], component: dict[str, Any]) -> list[str]:
    """The modes in which ``model``'s JSON schema differs from an OpenAPI ``component``."""
    out = []
    for mode in ("validation", "serialization"):
        mine = model.model_json_schema(ref_template="#/components/schemas/{model}", mode=mode)
        mine.pop("$defs", None)
        if _normalised(mine) != _normalised(component):
            out.append(mode)
    return out


def _components() -> dict[str, dict[str, Any]]:
    doc = json.loads(OPENAPI.read_text())
    return {
        name: comp
        for name, comp in doc["components"]["schemas"].items()
        if not name.startswith(FASTAPI_OWN)
    }


def test_copy_is_the_servers_module() -> None:
    tool = _sync_tool()
    expected = tool.client_copy((ROOT / "service" / "schemas.py").read_text())
    assert (ROOT / "conformorph_client" / "_schemas.py").read_text() == expected, SYNC_HINT


def test_every_api_model_of_the_document_is_the_clients() -> None:
    components = _components()
    assert len(components) >= 15  # the document has the API's models at all
    wrong = {}
    for name, component in components.items():
        model = getattr(_schemas, name, None)
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            wrong[name] = "missing"
        elif bad := schema_mismatches(model, component):
            wrong[name] = ",".join(bad)
    assert wrong == {}, SYNC_HINT


def test_every_exported_model_is_in_the_document() -> None:
    components = _components()
    exported = [
        getattr(models, n)
        for n in models.__all__
        if isinstance(getattr(models, n), type) and issubclass(getattr(models, n), BaseModel)
    ]
    assert len(exported) >= 15
    assert {m.__name__ for m in exported} <= set(components)
    assert models.JobErrorInfo is _schemas.JobError


def test_a_changed_model_is_caught() -> None:
    """The comparison fails on a field added, on a default changed and on a new type."""
    component = _components()["ErrorInfo"]
    assert schema_mismatches(_schemas.ErrorInfo, component) == []

    class ErrorInfo(_schemas.ErrorInfo):
        hint: str | None = None

    assert schema_mismatches(ErrorInfo, component) == ["validation", "serialization"]

    class ErrorInfo2(BaseModel):  # same fields, but field required where the server's is not
        type: str = Field(description="machine-readable error type")
        message: str
        field: str | None = Field(description="the input concerned, if any")

    ErrorInfo2.__name__ = "ErrorInfo"
    ErrorInfo2.model_config["title"] = "ErrorInfo"
    assert schema_mismatches(ErrorInfo2, component) != []


def test_client_copy_hand_worked_and_refusals() -> None:
    tool = _sync_tool()
    src = '"""doc"""\nfrom __future__ import annotations\n\nfrom pydantic import BaseModel\n'
    assert tool.client_copy(src) == tool.HEADER + src
    for bad in ("import numpy as np\n", "from conformorph.service.errors import ApiError\n", "from . import x\n"):
        with pytest.raises(ValueError, match="may import only"):
            tool.client_copy(src + bad)


def test_sync_tool_check_mode(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    tool = _sync_tool()
    monkeypatch.setattr(tool, "ROOT", tmp_path)
    monkeypatch.setattr(tool, "SOURCE", tmp_path / "schemas.py")
    monkeypatch.setattr(tool, "COPY", tmp_path / "_schemas.py")
    (tmp_path / "schemas.py").write_text("from pydantic import BaseModel\n")
    assert tool.main(["--check"]) == 1 and not (tmp_path / "_schemas.py").exists()
    assert tool.main([]) == 0
    assert (tmp_path / "_schemas.py").read_text().endswith("from pydantic import BaseModel\n")
    assert tool.main(["--check"]) == 0
    (tmp_path / "schemas.py").write_text("import numpy\n")
    assert tool.main([]) == 2
