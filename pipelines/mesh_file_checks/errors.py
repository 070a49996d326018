"""What a mesh file can be refused for, and the limits it is checked against.

Every refusal is a :class:`~conformorph.geometry.mesh_errors.MeshError` (a ``ValueError``)
with a message written for the person who made the file: what is wrong and
where (line, face or element number, JSON path), never an internal name.
"""

from __future__ import annotations

from dataclasses import dataclass

from conformorph.geometry.mesh_errors import MeshError


class UnsupportedFormatError(MeshError):
    """The file type is not one of :data:`conformorph.pipelines.mesh_io.MESH_TYPES` or the file cannot be parsed."""

    code = "unsupported_format"


class MalformedMeshFileError(UnsupportedFormatError):
    """The file's own structure is inconsistent: counts, sizes or indices that its bytes do not bear out."""

    code = "malformed_mesh_file"


class MeshTooLargeError(MeshError):
    """The file declares more vertices or faces than the limits allow."""

    code = "mesh_too_large"


@dataclass(frozen=True)
class MeshLimits:
    """Most vertices and faces a mesh file may declare (checked before it is parsed).

    Attributes
    ----------
    max_vertices : int or None
        Most vertices; None (the default) for no limit beyond the file's bytes.
    max_faces : int or None
        Most triangles; None (the default) for no limit beyond the file's bytes.
    """

    max_vertices: int | None = None
    max_faces: int | None = None

    def check(self, what: str, n_vertices: int | None, n_faces: int | None) -> None:
        """Raise :class:`MeshTooLargeError` when declared counts pass the limits.

        Parameters
        ----------
        what : str
            The file kind for the message (``"OBJ file"``).
        n_vertices, n_faces : int or None
            Declared counts (None: not known yet).
        """
        over_v = self.max_vertices is not None and (n_vertices or 0) > self.max_vertices
        over_f = self.max_faces is not None and (n_faces or 0) > self.max_faces
        if over_v or over_f:
            limits = [
                f"{n} {name}"
                for n, name in ((self.max_vertices, "vertices"), (self.max_faces, "faces"))
                if n is not None
            ]
            raise MeshTooLargeError(
                f"the {what} declares {n_vertices or 0} vertices and {n_faces or 0} faces; "
                f"the limits are {' and '.join(limits)}"
            )


def corner_problem(where: str, face: int, corners: int) -> str:
    """The message for a face with other than 3 corners."""
    return (
        f"{where}face {face} has {corners} corners; only triangles are accepted "
        "(triangulate the mesh first)"
    )


def shown(token: bytes | str, limit: int = 40) -> str:
    """A token from the file as it may appear in a message: quoted, at most ``limit`` characters."""
    text = token.decode("utf-8", errors="replace") if isinstance(token, bytes) else token
    return repr(text if len(text) <= limit else text[:limit] + "…")
