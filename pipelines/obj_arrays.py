"""A plain OBJ file's vertices and triangles, read without trimesh.

Most meshes users upload, and every face mesh the pipelines write, are OBJ files of
``v`` and ``f`` lines only (with, at most, texture coordinates, normals and vertex
colours beside them). Reading such a file is a matter of two regular expressions
and numpy's C text reader,
while importing trimesh costs a quarter of a second or more on every
``conformorph morph`` start (measured with ``python -X importtime``). This module
reads exactly that plain case, and says ``None`` to anything else, which
:func:`conformorph.pipelines.mesh_io.read_mesh` then gives to trimesh.
"""

from __future__ import annotations

import io
import re

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry._typing import FloatArray, IntArray

#: largest file (bytes) read here (numpy's C reader: 1.1 s for the 1.09M vertices and
#: 2.2M faces of a 116 MB file, where trimesh took about 8 s)
MAX_PLAIN_OBJ_BYTES = 2 << 30

#: a vertex line's numbers, a face line's corners, and what follows a corner's position
_V_LINE = re.compile(rb"^v[ \t]+([^\n#]*)", re.M)
_F_LINE = re.compile(rb"^f[ \t]+([^\n#]*)", re.M)
_AFTER_SLASH = re.compile(rb"/\S*")

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
    blocks = _two_blocks(data)
    if blocks is not None:
        return blocks
    v_rows = _V_LINE.findall(data)
    f_rows = _F_LINE.findall(data)
    if not f_rows or not v_rows:
        return None
    f_block = b"\n".join(f_rows)
    if b"/" in f_block:
        f_block = _AFTER_SLASH.sub(b"", f_block)  # "7/3/1" -> "7": the position index
    try:
        # numpy's C reader: every v row needs 3 numbers (extra ones, colours, are
        # skipped); every f row exactly 3 indices (a changing count is an error)
        V = np.loadtxt(io.BytesIO(b"\n".join(v_rows)), usecols=(0, 1, 2), ndmin=2, comments=None)
        F = np.loadtxt(io.BytesIO(f_block), dtype=np.int64, ndmin=2, comments=None)
    except ValueError:
        return None
    if V.shape != (len(v_rows), 3) or F.shape != (len(f_rows), 3) or np.any(F < 1):
        return None
    return V, F - 1


def _two_blocks(data: bytes) -> tuple[FloatArray, IntArray] | None:
    """The common layout read without splitting lines: every ``v x y z`` line, then every
    ``f a b c`` line (no other line, no slash); None for any other file."""
    cut = data.find(b"\nf ") + 1
    if cut <= 0 or not data.startswith(b"v "):
        return None
    v_block, f_block = data[:cut], data[cut:]
    n_v, n_f = v_block.count(b"\n"), f_block.count(b"\n") + (not f_block.endswith(b"\n"))
    if v_block.count(b"\nv ") + 1 != n_v or f_block.count(b"\nf ") + 1 != n_f:
        return None
    if b"/" in f_block or b"#" in data or b"\t" in data:
        return None
    try:
        V = np.loadtxt(io.BytesIO(v_block.replace(b"v ", b"")), usecols=(0, 1, 2), ndmin=2)
        F = np.loadtxt(io.BytesIO(f_block.replace(b"f ", b"")), dtype=np.int64, ndmin=2)
    except ValueError:
        return None
    if V.shape != (n_v, 3) or F.shape != (n_f, 3) or np.any(F < 1):
        return None
    return V, F - 1


def plain_obj_in_order(data: bytes, F: IntArray, n_vertices: int) -> bool:
    """Whether a plain OBJ file's faces refer only to vertices defined before them.

    Parameters
    ----------
    data : bytes
        The file, read by :func:`plain_obj_arrays`.
    F : (m, 3) int64
        Its faces, 0-based.
    n_vertices : int
        Its vertex count.

    Returns
    -------
    bool
        True when every index is below ``n_vertices`` and no vertex line follows
        the first face line (so every face's vertices come before it, as
        :func:`conformorph.pipelines.mesh_file_checks.obj.check_obj` requires);
        False says "check line by line".
    """
    if F.size == 0 or int(F.max()) >= n_vertices:
        return False
    # the first "f" line (as _F_LINE finds it), by bytes.find: a regex scan over the
    # vertex block took 0.5 s on a 116 MB file
    at = 0 if data.startswith((b"f ", b"f\t")) else _first_line_start(data, (b"\nf ", b"\nf\t"))
    if at < 0:
        return False
    return _first_line_start(data, (b"\nv ", b"\nv\t"), at) < 0


def _first_line_start(data: bytes, keys: tuple[bytes, ...], start: int = 0) -> int:
    """Where the first of ``keys`` (each ``\\n`` plus a line's start) occurs from
    ``start`` on, or -1."""
    found = [i for i in (data.find(k, start) for k in keys) if i >= 0]
    return min(found) if found else -1


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
