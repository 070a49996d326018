"""OFF files checked against their header's counts before trimesh reads them."""

from __future__ import annotations

import re

import numpy as np

from conformorph.geometry.mesh_errors import NotTrianglesError

from .errors import MalformedMeshFileError, MeshLimits, corner_problem, shown

_MAGIC = re.compile(rb"(COFF|OFF)")


def _bad(message: str) -> MalformedMeshFileError:
    return MalformedMeshFileError(f"the OFF file is malformed: {message}")


def _count(word: bytes, what: str) -> int:
    try:
        n = int(word)
    except ValueError:
        raise _bad(f"the header's {what} count {shown(word)} is not a whole number") from None
    if n < 0:
        raise _bad(f"the header's {what} count is negative ({n})")
    return n


def _face_line(lineno: int, face: int, words: list[bytes], n_v: int) -> None:
    """Check one face line: its corner count, the corners it gives, their indices."""
    try:
        k = int(words[0])
    except ValueError:
        raise _bad(
            f"line {lineno}: face {face} starts with {shown(words[0])}, not a corner count"
        ) from None
    given = len(words) - 1
    if k < 0 or given < k:
        raise _bad(f"line {lineno}: face {face} declares {k} corners but gives {given}")
    if k != 3:
        raise NotTrianglesError(
            "the OFF file is not all triangles: " + corner_problem(f"line {lineno}: ", face, k)
        )
    for w in words[1:4]:
        try:
            index = int(w)
        except ValueError:
            raise _bad(f"line {lineno}: face {face} corner {shown(w)} is not an index") from None
        if not 0 <= index < n_v:
            raise _bad(
                f"line {lineno}: face {face} refers to vertex {index}; the file has {n_v} "
                "vertices, numbered from 0"
            )


def _all_triangles(faces: list[tuple[int, list[bytes]]], n_v: int) -> bool:
    """True when every face line is ``3 i j k`` with indices in range (checked at once)."""
    if not faces:
        return True
    if any(len(w) != 4 for _, w in faces):
        return False
    try:
        table = np.array([w for _, w in faces]).astype(np.int64)
    except (ValueError, OverflowError):
        return False
    return bool(np.all(table[:, 0] == 3) and table[:, 1:].min() >= 0 and table[:, 1:].max() < n_v)


def check_off(data: bytes, limits: MeshLimits) -> tuple[int, int]:
    """Check an OFF file against its header; returns its declared (vertex, face) counts.

    Parameters
    ----------
    data : bytes
        The file.
    limits : MeshLimits

    Returns
    -------
    n_vertices, n_faces : int

    Raises
    ------
    MalformedMeshFileError
        No ``OFF`` header, counts that are not whole numbers, more vertices
        or faces declared than the file has lines, a vertex with fewer than 3
        numbers, a face that gives fewer corners than it declares, or a
        corner outside the vertices (each names its line).
    NotTrianglesError
        A face with other than 3 corners.
    MeshTooLargeError
        More vertices or faces declared than ``limits``.

    Notes
    -----
    The declared counts are compared with the lines present before any
    work proportional to them, so a hostile header costs nothing.
    """
    lines = [
        (lineno, words)
        for lineno, raw in enumerate(data.splitlines(), start=1)
        if (words := raw.split(b"#", 1)[0].split())
    ]
    match = _MAGIC.search(lines[0][1][0]) if lines else None
    if match is None:
        raise _bad("it does not start with the word OFF")
    rest = lines[0][1][0][match.end() :]
    first = ([rest] if rest else []) + lines[0][1][1:]
    if first:
        head_line, head, body = lines[0][0], first, lines[1:]
    elif len(lines) > 1:
        head_line, head, body = lines[1][0], lines[1][1], lines[2:]
    else:
        raise _bad("the vertex and face counts are missing after OFF")
    if len(head) < 2:
        raise _bad(f"line {head_line}: the header needs vertex and face counts")
    n_v, n_f = _count(head[0], "vertex"), _count(head[1], "face")
    limits.check("OFF file", n_v, n_f)
    if n_v + n_f > len(body):
        raise _bad(
            f"the header declares {n_v} vertices and {n_f} faces, one line each, but only "
            f"{len(body)} lines follow it"
        )
    if not _all_triangles(body[n_v : n_v + n_f], n_v):  # slow path: find the first fault
        for face, (lineno, words) in enumerate(body[n_v : n_v + n_f]):
            _face_line(lineno, face, words, n_v)
    for lineno, words in body[:n_v]:
        if len(words) < 3:
            raise _bad(f"line {lineno}: a vertex needs 3 coordinates, this one has {len(words)}")
    return n_v, n_f
