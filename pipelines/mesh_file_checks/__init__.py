"""Checks of a mesh file's own structure, run before it is parsed.

A file states counts, sizes and nesting (a PLY or OFF header's element
counts, a face's corner count, a binary STL's triangle count, a GLB's chunk
lengths, a glTF accessor's count); each is checked against the bytes that
really follow, and against the caller's :class:`MeshLimits`, before any
work proportional to it. The loops here advance through real bytes or
lines, so a hostile file costs what its size costs, and every refusal says
what is wrong and where.
"""

from __future__ import annotations

from pathlib import Path

from .errors import MalformedMeshFileError, MeshLimits, MeshTooLargeError, UnsupportedFormatError
from .gltf import check_glb, check_gltf_document
from .obj import check_obj
from .off import check_off
from .ply import check_ply
from .stl import check_stl


def check_mesh_file(
    data: bytes, file_type: str, limits: MeshLimits, *, folder: Path | None = None
) -> tuple[int | None, int | None]:
    """Check a mesh file's structure before parsing; returns the (vertex, face) counts it declares.

    Parameters
    ----------
    data : bytes
        The file.
    file_type : str
        One of ``obj``, ``ply``, ``off``, ``stl``, ``glb``, ``gltf``.
    limits : MeshLimits
        Most vertices and faces accepted.
    folder : Path, optional
        For a ``.gltf`` read from disk: its folder, where external buffers may
        lie; None refuses them.

    Returns
    -------
    n_vertices, n_faces : int or None
        As the file declares them (None where the format does not say).

    Raises
    ------
    MalformedMeshFileError, NotTrianglesError, MeshTooLargeError
        See the per-format checks.
    """
    if file_type == "obj":
        return check_obj(data, limits)
    if file_type == "off":
        return check_off(data, limits)
    if file_type == "ply":
        return check_ply(data, limits)
    if file_type == "stl":
        return check_stl(data, limits)
    if file_type == "glb":
        check_glb(data, limits)
    elif file_type == "gltf":
        check_gltf_document(data, "GLTF", limits, folder=folder)
    return None, None


__all__ = [
    "MalformedMeshFileError",
    "MeshLimits",
    "MeshTooLargeError",
    "UnsupportedFormatError",
    "check_mesh_file",
]
