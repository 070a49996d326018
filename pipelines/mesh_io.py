"""Reading triangle meshes from files or bytes, keeping the file's vertex order."""

from __future__ import annotations

import io
import json
from pathlib import Path
from urllib.parse import unquote

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


def _corner_problem(where: str, face: int, corners: int) -> str:
    return (
        f"{where}face {face} has {corners} corners; only triangles are accepted "
        "(triangulate the mesh first)"
    )


def _obj_polygon_problem(data: bytes) -> str | None:
    """Name the first OBJ face line with other than 3 corners (None if all are triangles)."""
    face = 0
    for lineno, raw in enumerate(data.splitlines(), start=1):
        if raw[:2] in (b"f ", b"f\t"):
            corners = len(raw[2:].split())
            if corners != 3:
                return _corner_problem(f"line {lineno}: ", face, corners)
            face += 1
    return None


def _off_polygon_problem(data: bytes) -> str | None:
    """Name the first OFF face with other than 3 corners (None if all are triangles)."""
    lines = (
        (lineno, raw.split(b"#", 1)[0].split())
        for lineno, raw in enumerate(data.splitlines(), start=1)
    )
    words = [(lineno, w) for lineno, w in lines if w]
    if not words or not words[0][1][0].endswith(b"OFF"):
        return None
    head = words[0][1][1:] or (words[1][1] if len(words) > 1 else [])
    start = 1 if words[0][1][1:] else 2
    try:
        n_v, n_f = int(head[0]), int(head[1])
    except (IndexError, ValueError):
        return None
    for face, (lineno, w) in enumerate(words[start + n_v : start + n_v + n_f]):
        try:
            corners = int(w[0])
        except ValueError:
            return None
        if corners != 3:
            return _corner_problem(f"line {lineno}: ", face, corners)
    return None


#: PLY scalar types as numpy dtype codes
_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
#: names of the face element's vertex index list in files seen in the wild
_PLY_INDEX_NAMES = ("vertex_indices", "vertex_index")


def _ply_polygon_problem(data: bytes) -> str | None:
    """Name the first PLY face with other than 3 corners (None if all are triangles).

    Reads the header and walks the records up to that face, ASCII or binary;
    ``None`` also when the file is too malformed to tell.
    """
    end = data.find(b"end_header")
    if end < 0:
        return None
    fmt = ""
    # elements: (name, count, properties (name, list-count dtype or None, item dtype))
    elements: list[tuple[str, int, list[tuple[str, str | None, str]]]] = []
    try:
        for line in data[:end].decode("ascii").splitlines():
            w = line.split()
            if w[:1] == ["format"]:
                fmt = w[1]
            elif w[:1] == ["element"]:
                elements.append((w[1], int(w[2]), []))
            elif w[:2] == ["property", "list"]:
                elements[-1][2].append((w[4], _PLY_TYPES[w[2]], _PLY_TYPES[w[3]]))
            elif w[:1] == ["property"]:
                elements[-1][2].append((w[2], None, _PLY_TYPES[w[1]]))
        body = data.index(b"\n", end) + 1
    except (IndexError, KeyError, ValueError, UnicodeDecodeError):
        return None
    if fmt == "ascii":
        rows = iter(data[body:].splitlines())
        for name, count, props in elements:
            for i in range(count):
                tokens = next(rows, b"").split()
                if name != "face":
                    continue
                k = 0
                for pname, count_type, _ in props:
                    if k >= len(tokens):
                        return None
                    if count_type is None:
                        k += 1
                        continue
                    n = int(float(tokens[k]))
                    if pname in _PLY_INDEX_NAMES and n != 3:
                        return _corner_problem("", i, n)
                    k += 1 + n
            if name == "face":
                return None
        return None
    order = "<" if fmt == "binary_little_endian" else ">"
    pos = body
    for name, count, props in elements:
        if all(count_type is None for _, count_type, _ in props) and name != "face":
            pos += count * sum(np.dtype(t).itemsize for _, _, t in props)
            continue
        for i in range(count):
            for pname, count_type, item in props:
                if count_type is None:
                    pos += np.dtype(item).itemsize
                    continue
                size = np.dtype(count_type).itemsize
                if pos + size > len(data):
                    return None
                n = int(np.frombuffer(data, order + count_type, 1, pos)[0])
                if name == "face" and pname in _PLY_INDEX_NAMES and n != 3:
                    return _corner_problem("", i, n)
                pos += size + n * np.dtype(item).itemsize
        if name == "face":
            return None
    return None


def _declared_counts(data: bytes, ftype: str) -> tuple[int | None, int | None]:
    """Vertex and face counts as the OBJ, OFF or PLY file states them (None if unknown)."""
    if ftype == "obj":
        n_v = n_f = 0
        for line in data.splitlines():
            head = line[:2]
            if head in (b"v ", b"v\t"):
                n_v += 1
            elif head in (b"f ", b"f\t"):
                n_f += 1
        return n_v, n_f
    if ftype == "off":
        words = []
        for raw in data[:4096].splitlines():
            words += raw.split(b"#", 1)[0].split()
            if len(words) >= 3:
                break
        try:
            return int(words[1]), int(words[2])
        except (IndexError, ValueError):
            return None, None
    if ftype == "ply":
        counts: dict[bytes, int] = {}
        for line in data[: data.find(b"end_header")].splitlines():
            w = line.split()
            if w[:1] == [b"element"] and len(w) == 3 and w[2].isdigit():
                counts[w[1]] = int(w[2])
        return counts.get(b"vertex"), counts.get(b"face")
    return None, None


_POLYGON_PROBLEM = {
    "obj": _obj_polygon_problem,
    "off": _off_polygon_problem,
    "ply": _ply_polygon_problem,
}


def _gltf_external_buffers(data: bytes) -> list[str]:
    """The buffer URIs of a glTF JSON document that are not embedded (``data:`` URIs)."""
    try:
        doc = json.loads(data)
    except (ValueError, RecursionError):
        return []
    if not isinstance(doc, dict):
        return []
    buffers = doc.get("buffers")
    uris = (
        [b.get("uri") for b in buffers if isinstance(b, dict)] if isinstance(buffers, list) else []
    )
    return [u for u in uris if isinstance(u, str) and not u.startswith("data:")]


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
        The file holds no mesh or several, or an OBJ, OFF or PLY face has
        other than 3 corners (the message names the first: line and face
        number, 0-based).
    OSError
        The path cannot be read.

    Notes
    -----
    trimesh merges and reorders vertices on load unless told not to
    (``process=False``, and ``maintain_order=True`` for OBJ); we pass both,
    and check that an OBJ's vertex count equals its ``v`` lines, so that
    landmark indices keep pointing at the vertices the user meant. STL has no
    shared vertices; its identical corner points are merged in order of
    first appearance. trimesh also triangulates polygons silently; the face
    count the file declares reveals them, and the file is then scanned for
    the first polygon. A ``.gltf`` read from a path may keep its buffers in
    ``.bin`` files beside it (read from that folder only); as bytes (an
    upload) its buffers must be embedded.
    """
    path: Path | None = None
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
    external = _gltf_external_buffers(data) if ftype == "gltf" else []
    if external and path is None:
        raise UnsupportedFormatError(
            f"the GLTF file refers to external buffer {external[0]!r}, which is not part of "
            "the upload; embed the buffers (data: URIs) or send a .glb"
        )
    if external and path is not None:
        missing = [u for u in external if not (path.parent / unquote(u)).is_file()]
        if missing:
            raise UnsupportedFormatError(
                f"the GLTF file refers to external buffer {missing[0]!r}, which is not "
                "beside it; keep the .bin files next to the .gltf, embed them, or use a .glb"
            )
    try:
        loaded = trimesh.load(
            # a .gltf is read from its path, so that its external buffers resolve
            # (trimesh only looks inside the file's own folder)
            str(path) if external and path is not None else io.BytesIO(data),
            file_type=ftype,
            process=False,
            maintain_order=True,
            skip_materials=True,
        )
    except Exception as exc:  # trimesh raises many types on malformed input
        where = _obj_face_problem(data) if ftype == "obj" else None
        polygon = _POLYGON_PROBLEM[ftype](data) if ftype in _POLYGON_PROBLEM else None
        if polygon:
            raise NotTrianglesError(
                f"the {ftype.upper()} file is not all triangles: {polygon}"
            ) from exc
        raise UnsupportedFormatError(
            f"cannot parse the {ftype.upper()} file: {where or exc}"
        ) from exc
    V, F = _to_arrays(loaded)
    n_v, n_f = _declared_counts(data, ftype)
    if ftype in _POLYGON_PROBLEM and n_f != F.shape[0]:
        # trimesh triangulates polygons on load: a face count unlike the file's tells
        polygon = _POLYGON_PROBLEM[ftype](data)
        if polygon:
            raise NotTrianglesError(f"the {ftype.upper()} file is not all triangles: {polygon}")
    if ftype == "stl":
        V, F = _merge_stl_corners(V, F)
    if ftype == "obj":
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
