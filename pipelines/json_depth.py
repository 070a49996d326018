"""How deep a JSON text nests, measured without parsing it (shapes, anchors, glTF)."""

from __future__ import annotations

import re

import numpy as np

#: the rest of a JSON string literal after its opening quote, up to and including the
#: closing one; possessive, so a failed match gives nothing back (linear in its length)
_STRING_REST = re.compile(r'(?:[^"\\]++|\\.)*+"', re.DOTALL)


def without_strings(text: str) -> str:
    """``text`` with every JSON string literal replaced by ``""``, in one linear pass.

    Parameters
    ----------
    text : str

    Returns
    -------
    str
        The text outside string literals, each literal written ``""``. An
        unterminated literal ends the text (it is then not JSON: the parser
        refuses it).

    Notes
    -----
    Each literal is matched once, from its own opening quote, by a possessive
    pattern, and the scan goes on after its closing quote, so every character
    is read a bounded number of times. A single regular expression searched
    over the whole text (``"[^"\\]*(?:\\.[^"\\]*)*"``) restarts at every
    quote of an unterminated run of ``\\"``: quadratic (issue 30: 120 KB took
    68 s).
    """
    out: list[str] = []
    pos = 0
    while (quote := text.find('"', pos)) >= 0:
        out.append(text[pos:quote])
        out.append('""')
        m = _STRING_REST.match(text, quote + 1)
        if m is None:
            return "".join(out)
        pos = m.end()
    out.append(text[pos:])
    return "".join(out)


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
    Computed without parsing, in time linear in the text (string literals
    removed by :func:`without_strings`) and bounded memory (1 MiB blocks), so
    that an over-deep document is refused with a message instead of the
    parser's ``RecursionError``.
    """
    raw = without_strings(text).encode("utf-8")
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
