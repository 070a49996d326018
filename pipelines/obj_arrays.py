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
