"""Copy the server's API models (``service/schemas.py``) into the client distribution.

The client (``conformorph_client/``, its own distribution ``conformorph-client``)
depends on httpx and pydantic only, so it cannot import the server's package.
It carries a copy of the schema module instead, ``conformorph_client/_schemas.py``,
which this script writes; ``tests/client/test_models_match.py`` fails, naming this
script, whenever the copy and the server's models (or ``openapi/openapi.json``)
differ. The jobs' shared defaults and ranges (``pipelines/job_fields.py``, pure
standard library), which the schema module imports, are copied likewise to
``conformorph_client/_job_fields.py``, and the copy's import is rewritten to it.

Usage: python tools/sync_client_models.py [--check]
(``--check`` writes nothing and exits 1 when the copy is out of date).
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "service" / "schemas.py"
COPY = ROOT / "conformorph_client" / "_schemas.py"
SHARED_SOURCE = ROOT / "pipelines" / "job_fields.py"
SHARED_COPY = ROOT / "conformorph_client" / "_job_fields.py"
HEADER = (
    "# A copy of the server's service/schemas.py, written by tools/sync_client_models.py:\n"
    "# edit the server's module and run that script, never this file.\n"
)
SHARED_HEADER = HEADER.replace("service/schemas.py", "pipelines/job_fields.py")
# the server module may import only these (a copy that imports the server could not install alone)
ALLOWED_IMPORTS = {
    "__future__",
    "re",
    "typing",
    "datetime",
    "enum",
    "pydantic",
    "collections",
    "math",
}
#: server modules the schema module may import, and the client copy's module for each
SHARED_MODULES = {"conformorph.pipelines.job_fields": "._job_fields"}


def client_copy(source: str) -> str:
    """The text of ``_schemas.py`` for the server module's text ``source``.

    Raises
    ------
    ValueError
        If ``source`` imports anything beyond the standard library modules and
        pydantic listed in ``ALLOWED_IMPORTS`` (the client must install alone).
    """
    _check_imports(source, "service/schemas.py", shared=True)
    for server, client in SHARED_MODULES.items():
        source = source.replace(f"from {server} import", f"from {client} import")
    return HEADER + source


def shared_copy(source: str) -> str:
    """The text of ``_job_fields.py`` for ``pipelines/job_fields.py``'s text ``source``.

    Raises
    ------
    ValueError
        If ``source`` imports anything beyond ``ALLOWED_IMPORTS``.
    """
    _check_imports(source, "pipelines/job_fields.py", shared=False)
    return SHARED_HEADER + source


def _check_imports(source: str, what: str, *, shared: bool) -> None:
    for line in source.splitlines():
        m = re.match(r"\s*(?:from\s+(\.*[\w.]*)\s+import|import\s+([\w.]+))", line)
        if m:
            full = m.group(1) or m.group(2)
            if shared and m.group(1) in SHARED_MODULES:
                continue
            if full.split(".")[0] not in ALLOWED_IMPORTS:
                raise ValueError(
                    f"{what} imports {full!r}: the client copy may import only the standard "
                    "library and pydantic"
                )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only check, write nothing")
    args = parser.parse_args(argv)
    try:
        copies = [
            (COPY, client_copy(SOURCE.read_text())),
            (SHARED_COPY, shared_copy(SHARED_SOURCE.read_text())),
        ]
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    status = 0
    for copy, text in copies:
        current = copy.read_text() if copy.is_file() else ""
        if current == text:
            print(f"{copy.name} is up to date")
        elif args.check:
            print(f"{copy.name} is out of date: run python tools/sync_client_models.py")
            status = 1
        else:
            copy.write_text(text)
            print(f"wrote {copy.name}")
    return status


if __name__ == "__main__":
    sys.exit(main())
