"""Reading triangle meshes from files or bytes, keeping the file's vertex order."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import trimesh

from geometry._typing import FloatArray, IntArray
from geometry.mesh_errors import MeshError, NotTrianglesError

#: file types read through trimesh, by lower-case extension
MESH_TYPES = ("obj", "ply", "off", "stl", "glb", "gltf")


class UnsupportedFormatError(MeshError):
    """The file type is not one of :data:`MESH_TYPES` or the file cannot be parsed."""

    code = "unsupported_format"


def _to_arrays(loaded: object) -> tuple[FloatArray, IntArray]:
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
        raise NotTrianglesError(f"the file holds no triangle mesh (found {type(loaded).__name__})")
    V = np.asarray(loaded.vertices, dtype=np.float64)
    F = np.asarray(loaded.faces, dtype=np.int64)
    return V, F


def _obj_face_problem(data: bytes) -> str | None:
    """Name the first OBJ face line whose vertex reference does not exist (None if all do).

    Run only after a parse failure, to say where the file is wrong.
    """
    n_v = 0
    for lineno, raw in enumerate(data.splitlines(), start=1):
        head = raw[:2]
        if head in (b"v ", b"v\t"):
            n_v += 1
        elif head in (b"f ", b"f\t"):
            for corner in raw[2:].split():
                try:
                    k = int(corner.split(b"/")[0])
                except ValueError:
                    return f"line {lineno}: face corner {corner.decode(errors='replace')!r} is not an index"
                index = k - 1 if k > 0 else n_v + k  # OBJ: 1-based, negatives count back
                if k == 0 or not 0 <= index < n_v:
                    return (
                        f"line {lineno}: face refers to vertex {k}, but only {n_v} vertices "
                        "are defined before it"
                    )
    return None


def _merge_stl_corners(V: FloatArray, F: IntArray) -> tuple[FloatArray, IntArray]:
    """STL stores every triangle corner separately: merge identical points, first occurrence first."""
    _, first, inverse = np.unique(V, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # unique rows ranked by first appearance
    rank = np.zeros_like(order)
    rank[order] = np.arange(order.size)
    return V[np.sort(first)], rank[inverse.reshape(-1)][F]


def read_mesh(
    source: str | Path | bytes, file_type: str | None = None
) -> tuple[FloatArray, IntArray]:
    """Read one triangle mesh, vertices in the file's order.

    Parameters
    ----------
    source : str, Path or bytes
        A path, or the file's bytes (then ``file_type`` is required).
    file_type : str, optional
        One of :data:`MESH_TYPES`; defaults to the path's extension.

    Returns
    -------
    V : (n, 3) float64
    F : (m, 3) int64

    Raises
    ------
    UnsupportedFormatError
        Unknown type or unparseable file.
    NotTrianglesError
        The file holds no mesh or several.
    OSError
        The path cannot be read.

    Notes
    -----
    trimesh merges and reorders vertices on load unless told not to
    (``process=False``, and ``maintain_order=True`` for OBJ); we pass both,
    and check that an OBJ's vertex count equals its ``v`` lines, so that
    landmark indices keep pointing at the vertices the user meant. STL has no
    shared vertices; its identical corner points are merged in order of
    first appearance.
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        ftype = (file_type or path.suffix.lstrip(".")).lower()
        data = path.read_bytes()
    else:
        if file_type is None:
            raise UnsupportedFormatError("file_type is required when reading bytes")
        ftype = file_type.lower()
        data = bytes(source)
    if ftype not in MESH_TYPES:
        raise UnsupportedFormatError(
            f"unsupported mesh type {ftype!r}; expected one of {', '.join(MESH_TYPES)}"
        )
    try:
        loaded = trimesh.load(
            io.BytesIO(data),
            file_type=ftype,
            process=False,
            maintain_order=True,
            skip_materials=True,
        )
    except Exception as exc:  # trimesh raises many types on malformed input
        where = _obj_face_problem(data) if ftype == "obj" else None
        raise UnsupportedFormatError(
            f"cannot parse the {ftype.upper()} file: {where or exc}"
        ) from exc
    V, F = _to_arrays(loaded)
    if ftype == "stl":
        V, F = _merge_stl_corners(V, F)
    if ftype == "obj":
        n_v = sum(1 for line in data.splitlines() if line[:2] in (b"v ", b"v\t"))
        if n_v != V.shape[0]:
            raise NotTrianglesError(
                f"the OBJ file has {n_v} vertices but {V.shape[0]} were read; "
                "vertex order would not be kept"
            )
    return V, F


def write_obj(path: str | Path, V: FloatArray, F: IntArray) -> None:
    """Write a triangle mesh as OBJ, vertices in the given order (1-based faces)."""
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in V]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    tmp = Path(str(path) + ".tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(path)
