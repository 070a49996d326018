"""Atomic output files: written under a temporary name in the same folder, then renamed.

Every output file of the pipelines (GLB, SVG, JSON, PNG) goes through
:func:`atomic_path` (or its text/bytes shorthands), so a reader never sees a
half-written file and a task run twice (``acks_late``) rewrites it safely.

The temporary file is created with mode ``0o666`` masked by the process's
umask, as ``open(path, "w")`` would create the final file: with the usual
umask 022 outputs are 0644, readable by a web server running as another user.
(``tempfile.mkstemp`` creates 0600 whatever the umask, and ``os.replace``
keeps that mode: issue 29.)
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path to write ``path``'s content to; renamed onto ``path`` on success.

    Parameters
    ----------
    path : str or Path
        The final file; its folder is created if missing.

    Yields
    ------
    Path
        An empty file in the same folder (mode ``0o666 & ~umask``), to be
        written (truncated) by the caller. On an exception in the block it is
        removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f".{path.name}.{uuid.uuid4().hex}.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_path`).

    Parameters
    ----------
    path : str or Path
    data : bytes
    """
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_path`).

    Parameters
    ----------
    path : str or Path
    text : str
    """
    atomic_write_bytes(path, text.encode("utf-8"))
