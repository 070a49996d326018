"""STL files: a binary file's triangle count checked against its size before trimesh reads it."""

from __future__ import annotations

import numpy as np

from .errors import MalformedMeshFileError, MeshLimits

#: bytes of a binary STL's header (80) and triangle count (4), and of one triangle record
HEADER_BYTES, TRIANGLE_BYTES = 84, 50


def check_stl(data: bytes, limits: MeshLimits) -> tuple[int, int]:
    """Check an STL file's triangle count; returns its (corner, triangle) counts.

    Parameters
    ----------
    data : bytes
        The file, binary or ASCII (``solid ...``).
    limits : MeshLimits

    Returns
    -------
    n_corners, n_triangles : int
        STL stores 3 corners per triangle (merged later).

    Raises
    ------
    MalformedMeshFileError
        A binary file whose size is not 84 + 50 × its declared triangle
        count (and is not ASCII STL), or an ASCII file whose facets do not
        each have 3 vertices.
    MeshTooLargeError
        More triangles than ``limits``.
    """
    if len(data) >= HEADER_BYTES:
        n = int(np.frombuffer(data, "<u4", 1, 80)[0])
        if HEADER_BYTES + TRIANGLE_BYTES * n == len(data):
            limits.check("STL file", 0, n)
            return 3 * n, n
    if data.lstrip()[:5].lower() == b"solid":
        facets = data.count(b"facet normal")
        corners = data.count(b"vertex")
        limits.check("STL file", 0, facets)
        if corners != 3 * facets:
            raise MalformedMeshFileError(
                f"the ASCII STL file is malformed: it has {facets} facets but {corners} "
                "vertex lines; each facet needs exactly 3"
            )
        return corners, facets
    if len(data) < HEADER_BYTES:
        raise MalformedMeshFileError(
            f"the STL file is malformed: {len(data)} bytes is shorter than a binary STL's "
            f"{HEADER_BYTES}-byte header, and it is not ASCII STL (no 'solid')"
        )
    raise MalformedMeshFileError(
        f"the binary STL file is malformed: its header declares {n} triangles, which take "
        f"{HEADER_BYTES + TRIANGLE_BYTES * n} bytes, but the file has {len(data)}"
    )
