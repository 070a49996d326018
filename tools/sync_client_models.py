"""Copy the server's API models (``service/schemas.py``) into the client distribution.

The client (``conformorph_client/``, its own distribution ``conformorph-client``)
depends on httpx and pydantic only, so it cannot import the server's package.
It carries a copy of the schema module instead, ``conformorph_client/_schemas.py``,
which this script writes; ``tests/client/test_models_match.py`` fails, naming this
script, whenever the copy and the server's models (or ``openapi/openapi.json``)
differ.

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
HEADER = (
    "# A copy of the server's service/schemas.py, written by tools/sync_client_models.py:\n"
    "# edit the server's module and run that script, never this file.\n"
)
# the server module may import only these (a copy that imports the server could not install alone)
ALLOWED_IMPORTS = {"__future__", "re", "typing", "datetime", "enum", "pydantic", "collections"}


def client_copy(source: str) -> str:
    """The text of ``_schemas.py`` for the server module's text ``source``.

    Raises
    ------
    ValueError
        If ``source`` imports anything beyond the standard library modules and
        pydantic listed in ``ALLOWED_IMPORTS`` (the client must install alone).
    """
    for line in source.splitlines():
        m = re.match(r"\s*(?:from\s+(\.*[\w.]*)\s+import|import\s+([\w.]+))", line)
        if m:
            name = (m.group(1) or m.group(2)).split(".")[0]
            if name not in ALLOWED_IMPORTS:
                raise ValueError(
                    f"service/schemas.py imports {(m.group(1) or m.group(2))!r}: the client "
                    "copy may import only the standard library and pydantic"
                )
    return HEADER + source


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only check, write nothing")
    args = parser.parse_args(argv)
    try:
        text = client_copy(SOURCE.read_text())
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    current = COPY.read_text() if COPY.is_file() else ""
    if current == text:
        print(f"{COPY.relative_to(ROOT)} is up to date")
        return 0
    if args.check:
        print(f"{COPY.relative_to(ROOT)} is out of date: run python tools/sync_client_models.py")
        return 1
    COPY.write_text(text)
    print(f"wrote {COPY.relative_to(ROOT)} from {SOURCE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
