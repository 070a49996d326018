"""How deep a JSON text nests, measured without parsing it (shapes, anchors, glTF)."""

from __future__ import annotations

import re

import numpy as np

#: a JSON string literal, written as an unrolled loop (no backtracking per character)
_JSON_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"')


def json_depth(text: str) -> int:
    """Deepest nesting of ``[`` and ``{`` in JSON text (brackets inside strings ignored).

    Parameters
    ----------
    text : str

    Returns
    -------
    int
        0 for a bare scalar, 1 for ``[1, 2]``, 2 for ``{"a": [1]}``, …

    Notes
    -----
    Computed without parsing, in bounded memory (1 MiB blocks), so that an
    over-deep document is refused with a message instead of the parser's
    ``RecursionError``.
    """
    raw = _JSON_STRING.sub('""', text).encode("utf-8")
    depth = best = 0
    block = 1 << 20
    for k in range(0, len(raw), block):
        x = np.frombuffer(raw, dtype=np.uint8, count=min(block, len(raw) - k), offset=k)
        step = (
            (x == ord("[")).astype(np.int32) + (x == ord("{")) - (x == ord("]")) - (x == ord("}"))
        )
        level = np.cumsum(step) + depth
        best = max(best, int(level.max()))
        depth = int(level[-1])
    return best
