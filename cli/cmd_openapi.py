"""``conformorph openapi [-o openapi/openapi.json]``: write the API's OpenAPI document."""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path
from typing import Any


def openapi_text() -> str:
    """The OpenAPI document as stable, indented JSON (built with throw-away state)."""
    from conformorph.service.core.config import Settings
    from conformorph.service.main import create_app

    with tempfile.TemporaryDirectory(prefix="conformorph-openapi-") as d:
        app = create_app(Settings(data_dir=Path(d), database_url="sqlite://"))
        return json.dumps(app.openapi(), indent=2, sort_keys=True, ensure_ascii=False) + "\n"


def run_openapi(args: argparse.Namespace) -> int:
    text = openapi_text()
    if args.output == "-":
        print(text, end="")
        return 0
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(out)
    print(f"wrote {out}")
    return 0


def register(sub: Any) -> None:
    """Add the ``openapi`` command."""
    p = sub.add_parser("openapi", help="write the OpenAPI document of the REST API")
    p.add_argument(
        "-o", "--output", default="openapi/openapi.json", help="output file, or - for stdout"
    )
    p.set_defaults(handler=run_openapi)
