"""OBJ files checked line by line before trimesh reads them."""

from __future__ import annotations

from conformorph.geometry.mesh_errors import NotTrianglesError

from .errors import MalformedMeshFileError, MeshLimits, corner_problem, shown


def _face_indices(lineno: int, corners: list[bytes], n_v: int) -> None:
    """Check the corners of one ``f`` line against the ``n_v`` vertices defined before it."""
    for corner in corners:
        try:
            k = int(corner.split(b"/")[0])
        except ValueError:
            raise MalformedMeshFileError(
                f"the OBJ file is malformed: line {lineno}: face corner {shown(corner)} "
                "is not an index"
            ) from None
        if k == 0:
            raise MalformedMeshFileError(
                f"the OBJ file is malformed: line {lineno}: face refers to vertex 0, which "
                "does not exist (OBJ numbers vertices from 1)"
            )
        index = k - 1 if k > 0 else n_v + k  # OBJ: 1-based, negatives count back
        if not 0 <= index < n_v:
            raise MalformedMeshFileError(
                f"the OBJ file is malformed: line {lineno}: face refers to vertex {k}, but "
                f"only {n_v} vertices are defined before it"
            )


def check_obj(data: bytes, limits: MeshLimits) -> tuple[int, int]:
    """Check an OBJ file's vertex and face lines; returns its (vertex, face) counts.

    Parameters
    ----------
    data : bytes
        The file.
    limits : MeshLimits

    Returns
    -------
    n_vertices, n_faces : int
        Its ``v`` and ``f`` lines.

    Raises
    ------
    MalformedMeshFileError
        A vertex with fewer than 3 numbers, a face corner that is not an
        index, or that refers to vertex 0 or to one not defined before it
        (the message names the line).
    NotTrianglesError
        A face with other than 3 corners (line and 0-based face number).
    MeshTooLargeError
        More vertices or faces than ``limits``.

    Notes
    -----
    One pass over the lines: the cost follows the file's bytes.
    """
    n_v = n_f = 0
    for lineno, raw in enumerate(data.splitlines(), start=1):
        head = raw[:2]
        if head in (b"v ", b"v\t"):
            words = raw.split()
            if len(words) < 4:
                raise MalformedMeshFileError(
                    f"the OBJ file is malformed: line {lineno}: a vertex needs 3 coordinates, "
                    f"this one has {len(words) - 1}"
                )
            for w in words[1:4]:
                try:
                    float(w)
                except ValueError:
                    raise MalformedMeshFileError(
                        f"the OBJ file is malformed: line {lineno}: vertex coordinate "
                        f"{shown(w)} is not a number"
                    ) from None
            n_v += 1
        elif head in (b"f ", b"f\t"):
            corners = raw[2:].split()
            if len(corners) != 3:
                raise NotTrianglesError(
                    "the OBJ file is not all triangles: "
                    + corner_problem(f"line {lineno}: ", n_f, len(corners))
                )
            _face_indices(lineno, corners, n_v)
            n_f += 1
    limits.check("OBJ file", n_v, n_f)
    return n_v, n_f
