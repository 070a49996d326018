"""Reading triangle meshes from files or bytes, keeping the file's vertex order.

The file's own structure is checked first (:mod:`conformorph.pipelines.mesh_file_checks`:
declared counts and sizes against the real bytes, face corners, indices,
external references), then trimesh parses it (a plain OBJ file of ``v`` and ``f``
lines is read by :mod:`conformorph.pipelines.obj_arrays`, without importing trimesh).
"""

from __future__ import annotations

import io
import logging
from pathlib import Path

import numpy as np

from conformorph.geometry._typing import FloatArray, IntArray
from conformorph.geometry.mesh_errors import MeshError, NotTrianglesError
from conformorph.pipelines.job_fields import FieldRangeError, check_extent
from conformorph.pipelines.mesh_file_checks import (
    MalformedMeshFileError,
    MeshLimits,
    MeshTooLargeError,
    UnsupportedFormatError,
    check_mesh_file,
)
from conformorph.pipelines.obj_arrays import (
    plain_obj_arrays,
    plain_obj_in_order,
    simple_obj_arrays,
)

#: file types read through trimesh, by lower-case extension
MESH_TYPES = ("obj", "ply", "off", "stl", "glb", "gltf")

__all__ = [
    "MESH_TYPES",
    "MalformedMeshFileError",
    "MeshLimits",
    "MeshTooLargeError",
    "UnsupportedFormatError",
    "read_mesh",
    "write_obj",
]

log = logging.getLogger(__name__)


def _to_arrays(loaded: object) -> tuple[FloatArray, IntArray]:
    import trimesh

    if isinstance(loaded, trimesh.Scene):
        geoms = list(loaded.geometry.values())
        if not geoms:
            raise NotTrianglesError("the file holds no mesh: no vertices and faces could be read")
        if len(geoms) != 1:
            raise NotTrianglesError(
                f"the file holds {len(geoms)} meshes; upload exactly one mesh per file"
            )
        loaded = geoms[0]
    if not isinstance(loaded, trimesh.Trimesh):
        raise NotTrianglesError("the file holds points or lines but no triangle mesh")
    V = np.asarray(loaded.vertices, dtype=np.float64)
    F = np.asarray(loaded.faces)
    if F.size == 0:
        F = F.reshape(0, 3)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise NotTrianglesError(
            "the file's mesh is not 3D points and triangles (positions need x, y, z and "
            "faces 3 corners)"
        )
    if not np.issubdtype(F.dtype, np.integer) and not np.all(np.isfinite(F) & (F == np.round(F))):
        raise NotTrianglesError("the file's face indices are not whole numbers")
    return V, F.astype(np.int64)


def _merge_stl_corners(V: FloatArray, F: IntArray) -> tuple[FloatArray, IntArray]:
    """STL stores every triangle corner separately: merge identical points, first occurrence first."""
    _, first, inverse = np.unique(V, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # unique rows ranked by first appearance
    rank = np.zeros_like(order)
    rank[order] = np.arange(order.size)
    return V[np.sort(first)], rank[inverse.reshape(-1)][F]


def _source_bytes(
    source: str | Path | bytes, file_type: str | None
) -> tuple[bytes, str, Path | None]:
    """The file's bytes, its lower-case type and its path (None for bytes)."""
    if isinstance(source, (str, Path)):
        path = Path(source)
        return path.read_bytes(), (file_type or path.suffix.lstrip(".")).lower(), path
    if file_type is None:
        raise UnsupportedFormatError("file_type is required when reading bytes")
    return bytes(source), file_type.lower(), None


def _parse(data: bytes, ftype: str, path: Path | None) -> object:
    """trimesh's reading of a file that passed the structure checks."""
    # a .gltf from disk is read from its path, so that its external buffers
    # (checked to lie in its folder) resolve; everything else from the bytes
    import trimesh  # imported here: plain OBJ files never need it (pipelines.obj_arrays)

    from_path = ftype == "gltf" and path is not None and b'"uri"' in data
    try:
        return trimesh.load(
            str(path) if from_path else io.BytesIO(data),
            file_type=ftype,
            process=False,
            maintain_order=True,
            skip_materials=True,
        )
    except Exception as exc:  # trimesh raises many types on malformed input
        log.debug("trimesh could not read a %s file", ftype, exc_info=True)
        raise UnsupportedFormatError(
            f"cannot parse the {ftype.upper()} file: its contents are not a valid "
            f"{ftype.upper()} mesh (check that the file is complete and holds numbers "
            "where the format expects them)"
        ) from exc


def read_mesh(
    source: str | Path | bytes,
    file_type: str | None = None,
    *,
    limits: MeshLimits | None = None,
) -> tuple[FloatArray, IntArray]:
    """Read one triangle mesh, vertices in the file's order.

    Parameters
    ----------
    source : str, Path or bytes
        A path, or the file's bytes (then ``file_type`` is required).
    file_type : str, optional
        One of :data:`MESH_TYPES`; defaults to the path's extension.
    limits : MeshLimits, optional
        Most vertices and faces the file may declare, checked before it is
        parsed (default: no limit beyond the file's own bytes).

    Returns
    -------
    V : (n, 3) float64
    F : (m, 3) int64

    Raises
    ------
    UnsupportedFormatError
        Unknown type or unparseable file; its subclass
        :class:`MalformedMeshFileError` when the file's structure is
        inconsistent (a declared count, size or index its bytes do not bear
        out, a reference outside the file), naming where.
    NotTrianglesError
        The file holds no mesh or several, or an OBJ, OFF or PLY face has
        other than 3 corners (the message names the first: line and face
        number, 0-based).
    MeshTooLargeError
        More vertices or faces declared than ``limits``.
    OSError
        The path cannot be read.

    Notes
    -----
    trimesh merges and reorders vertices on load unless told not to
    (``process=False``, and ``maintain_order=True`` for OBJ); we pass both,
    and check that the vertex and face counts read equal the file's own, so
    that landmark indices keep pointing at the vertices the user meant. STL
    has no shared vertices; its identical corner points are merged in order
    of first appearance. Polygons, which trimesh would triangulate silently,
    are refused by the structure checks. A ``.gltf`` read from a path may
    keep its buffers in files beside it (names resolved, links followed, and
    refused when they lead out of that folder); as bytes (an upload) it may
    refer only to its own embedded data, and every other reference gets the
    same message.
    """
    data, ftype, path = _source_bytes(source, file_type)
    if ftype not in MESH_TYPES:
        raise UnsupportedFormatError(
            f"unsupported mesh type {ftype!r}; expected one of {', '.join(MESH_TYPES)}"
        )
    folder = path.parent if path is not None else None
    plain = plain_obj_arrays(data) if ftype == "obj" else None
    if ftype == "obj":  # valid by construction: only the limits are left to check
        # a plain file whose faces follow their vertices: what check_obj's line loop
        # would establish (3 numbers a vertex, 3 corners a face, indices from 1 to the
        # vertices before them) is already proven by the arrays (3 s of Python saved
        # at 1M vertices); else a "simple" one, v and f lines interleaved
        in_order = plain is not None and plain_obj_in_order(data, plain[1], len(plain[0]))
        done = plain if in_order else simple_obj_arrays(data)
        if done is not None:
            (limits or MeshLimits()).check("OBJ file", done[0].shape[0], done[1].shape[0])
            return _in_range(*done)
    n_v, n_f = check_mesh_file(data, ftype, limits or MeshLimits(), folder=folder)
    V, F = plain if plain is not None else _to_arrays(_parse(data, ftype, path))
    if ftype == "stl":
        V, F = _merge_stl_corners(V, F)
    elif n_v is not None and (n_v, n_f) != (V.shape[0], F.shape[0]):
        raise MalformedMeshFileError(
            f"the {ftype.upper()} file declares {n_v} vertices and {n_f} faces but "
            f"{V.shape[0]} and {F.shape[0]} were read; vertex order would not be kept"
        )
    return _in_range(V, F)


class CoordinateRangeError(MeshError):
    """Vertex coordinates outside the range the numerics honour
    (:func:`conformorph.pipelines.job_fields.check_extent`)."""

    code = "out_of_range"


def _in_range(V: FloatArray, F: IntArray) -> tuple[FloatArray, IntArray]:
    """``(V, F)`` once the coordinates are within ``COORDINATE_LIMIT`` and the extent is
    not lost in their magnitude (a mesh at 1e300 overflowed every area downstream).

    Raises
    ------
    CoordinateRangeError
    """
    if V.size:
        largest = float(np.abs(V).max())
        # scaled by the largest coordinate: no overflow (refused on it first when too large)
        scale = largest if 0.0 < largest < np.inf else 1.0
        extent = scale * float(np.linalg.norm((V.max(axis=0) - V.min(axis=0)) / scale))
        try:
            check_extent(largest, extent, "the mesh")
        except FieldRangeError as exc:
            raise CoordinateRangeError(str(exc)) from exc
    return V, F


def write_obj(path: str | Path, V: FloatArray, F: IntArray) -> None:
    """Write a triangle mesh as OBJ, vertices in the given order (1-based faces)."""
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in V]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    tmp = Path(str(path) + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(path)
