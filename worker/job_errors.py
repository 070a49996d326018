"""A failed job's ``error`` in the API's language: named codes, field names, no paths.

The pipelines are shared with the CLI, so their messages may name a file path
(``/srv/data/artifacts/meshs/key-4e5c…/33ae….obj: …``) or a flag
(``--texture``). A job's error is read by an API client, to whom the server's
data directory, the owner's key id and the CLI's flags mean nothing (and the
first two must not be shown). :func:`api_error_type` names the error by our own
code (never a Python class name such as ``ValueError``) and
:func:`api_message` rewrites the text: paths and key ids are replaced by the
input concerned, flags by the job fields that say the same.
"""

from __future__ import annotations

import re

#: our code for an error whose class carries none (``code``), most specific first
ERROR_CODES: tuple[tuple[type[BaseException], str], ...] = (
    (ZeroDivisionError, "numerical_failure"),
    (OverflowError, "numerical_failure"),
    (FloatingPointError, "numerical_failure"),
    (ArithmeticError, "numerical_failure"),
    (LookupError, "invalid_input"),
    (ValueError, "invalid_input"),
)

#: CLI flags whose job field is not the flag with ``-`` made ``_``
FLAG_FIELDS = {
    "--texture": "textures",
    "--consistent-mesh": "consistent",
    "--no-fold-correction": "fold_correction",
    "--no-refine-angles": "refine_angles",
    "--max-points": "point_budget",
    "--anchors": "anchors",
    "--paths": "paths",
}

_FLAG = re.compile(r"(?<![\w-])--([a-z][a-z0-9]*(?:-[a-z0-9]+)*)")
_KEY_ID = re.compile(r"key-[0-9a-f]{6,}")
#: a file extension at the end of a path token (before trailing punctuation)
_EXTENSION = re.compile(r"\.[A-Za-z0-9]{1,5}[:,;.)]*$")


def api_error_type(exc: BaseException) -> str:
    """The error's code: its own ``code``, else our name for its class.

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    str
        ``exc.code`` when it is a string, else the first of :data:`ERROR_CODES`
        whose class ``exc`` is an instance of, else ``"internal_error"``.
    """
    code = getattr(exc, "code", None)
    if isinstance(code, str):
        return code
    for cls, name in ERROR_CODES:
        if isinstance(exc, cls):
            return name
    return "internal_error"


def _is_path(token: str) -> bool:
    """A whitespace-free token that names a file: absolute (``/…``, ``~/…``, ``C:\\…``),
    or relative with a file extension (``a/b.obj``) or a key id (``key-…/…``)."""
    core = token.strip("'\"()[],;")
    if ("/" not in core and "\\" not in core) or "://" in core:
        return False  # no path, or a URL (kept: it is the client's own)
    if core.startswith(("/", "~", "./", "../")) or re.match(r"^[A-Za-z]:[\\/]", core):
        return True
    return _EXTENSION.search(core) is not None or _KEY_ID.search(core) is not None


def api_message(text: str, field: str | None = None) -> str:
    """``text`` with paths and key ids replaced by the input, flags by job fields.

    Parameters
    ----------
    text : str
        The exception's message (whitespace is collapsed).
    field : str, optional
        The input concerned (``meshes[1]``), which replaces a path; else
        "the input file".

    Returns
    -------
    str
        Linear in the text's length.

    Examples
    --------
    >>> api_message("/d/artifacts/meshs/key-4e5c00aa11bb22cc/33.obj: --texture needs UVs",
    ...             "meshes[1]")
    'meshes[1]: textures needs UVs'
    """
    name = field or "the input file"
    words = []
    for token in text.split():
        if _is_path(token):
            tail = token[len(token.rstrip(":,;.)")) :]
            words.append(name + tail)
        else:
            words.append(_KEY_ID.sub("key", token))
    out = " ".join(words)
    return _FLAG.sub(lambda m: FLAG_FIELDS.get(m.group(0), m.group(1).replace("-", "_")), out)
