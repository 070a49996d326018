"""A plain OBJ file's vertices and triangles, read without trimesh.

Most meshes users upload, and every face mesh the pipelines write, are OBJ files of
``v`` and ``f`` lines only (with, at most, texture coordinates, normals and vertex
colours beside them). Reading such a file is a matter of two list comprehensions,
while importing trimesh costs a quarter of a second or more on every
``conformorph morph`` start (measured with ``python -X importtime``). This module
reads exactly that plain case, and says ``None`` to anything else, which
:func:`conformorph.pipelines.mesh_io.read_mesh` then gives to trimesh.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry._typing import FloatArray, IntArray

#: largest file (bytes) read here; a larger one goes to trimesh's vectorised parser,
#: which is faster per line than Python's string splitting on millions of lines
MAX_PLAIN_OBJ_BYTES = 8 << 20

#: line keywords after which a file is no longer "plain": objects, groups and
#: materials may make trimesh split the file into several meshes (which read_mesh
#: refuses, naming the count), and a continuation line joins two lines
_NOT_PLAIN = (b"\no ", b"\ng ", b"\nusemtl", b"\\\n", b"\\\r\n")


def plain_obj_arrays(data: bytes) -> tuple[FloatArray, IntArray] | None:
    """The vertices and triangles of a plain OBJ file, or None when it is not plain.

    Parameters
    ----------
    data : bytes
        The file, already through :func:`conformorph.pipelines.mesh_file_checks.check_mesh_file`
        (faces are triangles, indices are in range and not 0).

    Returns
    -------
    (V, F) or None
        ``V`` (n, 3) float64, the ``v`` lines' first three numbers in file order;
        ``F`` (m, 3) int64, the ``f`` lines' position indices made 0-based. None when
        the file is larger than :data:`MAX_PLAIN_OBJ_BYTES`, has no ``f`` line, has
        objects, groups, materials, continuation lines or negative (relative)
        indices, or a number that does not parse: trimesh reads those.

    Notes
    -----
    On a plain file this gives what ``trimesh.load(..., process=False,
    maintain_order=True)`` gives (``tests/pipelines/test_obj_arrays.py`` compares the
    two on every committed and shared OBJ file).

    Examples
    --------
    >>> V, F = plain_obj_arrays(b"v 0 0 0\\nv 1 0 0\\nv 0 1 0 0.5 0.5 0.5\\nf 1/1 2/2 3/3\\n")
    >>> V.shape, F.tolist()
    ((3, 3), [[0, 1, 2]])
    """
    if len(data) > MAX_PLAIN_OBJ_BYTES:
        return None
    head = b"\n" + data
    if any(k in head for k in _NOT_PLAIN):
        return None
    vs: list[list[bytes]] = []
    fs: list[list[bytes]] = []
    for line in data.splitlines():
        if line.startswith(b"v "):
            vs.append(line.split()[1:4])
        elif line.startswith(b"f "):
            fs.append([t.split(b"/", 1)[0] for t in line.split()[1:4]])
    if not fs or any(len(v) != 3 for v in vs) or any(len(f) != 3 for f in fs):
        return None
    try:
        V = np.array(vs, dtype=np.float64).reshape(-1, 3)
        F = np.array(fs, dtype=np.int64).reshape(-1, 3)
    except ValueError:
        return None
    if np.any(F < 1):
        return None
    return V, F - 1


#: bytes a "simple" OBJ file may hold (see :func:`simple_obj_arrays`)
_SIMPLE_BYTES = np.zeros(256, dtype=bool)
_SIMPLE_BYTES[list(b"0123456789.eE+-vf \t\r\n")] = True
_WHITESPACE = np.zeros(256, dtype=bool)
_WHITESPACE[list(b" \t\r\n")] = True
#: longest face index read here (an int64 holds 18 decimal digits)
_MAX_INDEX_DIGITS = 18


def _token_starts(arr: NDArray[np.uint8]) -> tuple[IntArray, IntArray] | None:
    """Start of every whitespace-separated token, (4 k,), and of every line's first
    token, (k,), when every non-blank line has exactly 4 tokens, the first a lone
    ``v`` or ``f`` at the start of the line followed by a space; else None."""
    ws = _WHITESPACE[arr]
    starts = np.flatnonzero(~ws & np.r_[True, ws[:-1]])
    if starts.size == 0 or starts.size % 4:
        return None
    newlines = np.flatnonzero(arr == 10)
    line = np.searchsorted(newlines, starts)
    per_line = np.bincount(line)
    if np.any((per_line != 0) & (per_line != 4)):
        return None
    first = starts[::4]  # every line's tokens are consecutive: a line's first is every 4th
    at_line_start = (first == 0) | (arr[np.maximum(first - 1, 0)] == 10)
    kw = arr[first]
    if not (np.all(at_line_start) and np.all((kw == ord("v")) | (kw == ord("f")))):
        return None
    if np.any(arr[first + 1] != ord(" ")):  # a lone keyword, one space (as plain_obj_arrays)
        return None
    return starts, first


def simple_obj_arrays(data: bytes) -> tuple[FloatArray, IntArray] | None:
    """A "simple" OBJ file's vertices and triangles, read with vectorised checks; else None.

    Parameters
    ----------
    data : bytes
        The whole file (not yet checked).

    Returns
    -------
    (V, F) or None
        ``V`` (n, 3) float64 and ``F`` (m, 3) int64 (0-based), exactly what
        :func:`conformorph.pipelines.mesh_file_checks.check_mesh_file` followed by
        :func:`plain_obj_arrays` give, when the file is "simple": only ``v x y z`` and
        ``f i j k`` lines (keyword at the line start, one space after it, positive
        indices without ``/``, each at most a vertex defined before its line) and
        blank lines, ``\\n`` or ``\\r\\n`` line ends, at least one face. None for
        anything else (comments, texture coordinates, colours, ``v\\t``, a number
        that does not parse, ...): the line-by-line checks then read the file and
        name any problem.

    Notes
    -----
    The line-by-line path costs Python string work per line and holds the GIL, so
    two key meshes read on two threads take one after the other: 0.5 s per
    68k-vertex file, against about 0.15 s here (numpy's bytes-to-float
    conversion parses as Python's ``float`` does, so the numbers are identical;
    ``tests/pipelines/test_obj_arrays.py`` compares the two paths).

    Examples
    --------
    >>> V, F = simple_obj_arrays(b"v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 3\\n")
    >>> V.shape, F.tolist()
    ((3, 3), [[0, 1, 2]])
    >>> simple_obj_arrays(b"# a comment\\nv 0 0 0\\nv 1 0 0\\nv 0 1 0\\nf 1 2 3\\n") is None
    True
    """
    arr = np.frombuffer(data, dtype=np.uint8)
    if arr.size == 0 or not _SIMPLE_BYTES[arr].all():
        return None
    cr = np.flatnonzero(arr == 13)  # only as part of \r\n (a lone \r ends a line too)
    if cr.size and (cr[-1] + 1 >= arr.size or np.any(arr[cr + 1] != 10)):
        return None
    found = _token_starts(arr)
    if found is None:
        return None
    starts, first = found
    tokens = data.split()
    if len(tokens) != starts.size:
        return None
    table = np.array(tokens).reshape(-1, 4)
    is_v = arr[first] == ord("v")
    if is_v.all():
        return None
    faces = table[~is_v, 1:]
    digits = faces.view(np.uint8).reshape(faces.shape[0], 3, -1)
    if faces.dtype.itemsize > _MAX_INDEX_DIGITS and np.any(digits[..., _MAX_INDEX_DIGITS:]):
        return None
    if np.any((digits != 0) & ((digits < ord("0")) | (digits > ord("9")))):
        return None
    try:
        V = table[is_v, 1:].astype(np.float64)
        F = faces.astype(np.int64)
    except ValueError:
        return None
    defined = np.cumsum(is_v)[~is_v]  # vertices defined before each face line
    if np.any(F < 1) or np.any(F.max(axis=1) > defined):
        return None
    return V.reshape(-1, 3), F.reshape(-1, 3) - 1
