"""glTF documents (``.gltf`` JSON and ``.glb`` containers) checked before trimesh reads them.

Every length, offset and count the document declares is compared with the
bytes that back it (the GLB's chunks, ``data:`` URIs, or files beside a
``.gltf`` read from disk) before anything is allocated for it, and every
index must name an existing object.
"""

from __future__ import annotations

import base64
import binascii
import json
import struct
from pathlib import Path
from typing import Any, TypeGuard
from urllib.parse import unquote

from conformorph.pipelines.json_depth import json_depth

from .errors import MalformedMeshFileError, MeshLimits

#: deepest JSON nesting read in a glTF document (the format itself needs 6)
MAX_GLTF_JSON_DEPTH = 64
_GLB_MAGIC, _JSON_CHUNK, _BIN_CHUNK = b"glTF", 0x4E4F534A, 0x004E4942
_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_INDEX_TYPES = (5121, 5123, 5125)  # unsigned byte, short, int
_TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
#: the one answer to any reference outside an uploaded document, whatever it names
OUTSIDE_UPLOAD = (
    "the GLTF file refers to data outside itself ({where}); an upload must embed its "
    "buffers and images (data: URIs) or be sent as a .glb"
)


def _bad(kind: str, message: str) -> MalformedMeshFileError:
    return MalformedMeshFileError(f"the {kind} file is malformed: {message}")


def _index(value: Any, n: int) -> TypeGuard[int]:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < n


def _count(value: Any) -> TypeGuard[int]:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _list(doc: dict[str, Any], key: str, kind: str) -> list[dict[str, Any]]:
    items = doc.get(key, [])
    if not isinstance(items, list) or not all(isinstance(x, dict) for x in items):
        raise _bad(kind, f"'{key}' must be a list of objects")
    return items


def _data_uri_bytes(uri: str, where: str, kind: str) -> int:
    """Decoded size of a ``data:`` URI (only base64 ones hold binary data)."""
    head, sep, payload = uri.partition(",")
    if not sep or not head.endswith(";base64"):
        raise _bad(kind, f"{where}: a data: URI must be base64 ('data:...;base64,...')")
    try:
        return len(base64.b64decode(payload, validate=True))
    except (binascii.Error, ValueError):
        raise _bad(kind, f"{where}: the data: URI is not valid base64") from None


def external_file(uri: str, folder: Path) -> Path | None:
    """The file a relative URI names inside ``folder``, or None when it names anything else.

    Links are resolved: a name that leads out of ``folder`` (absolute, ``..``,
    a symbolic link pointing elsewhere) or to no regular file gives None.
    """
    name = unquote(uri)
    if not name or "\\" in name or "://" in name or Path(name).is_absolute():
        return None
    if any(part in ("", "..") for part in name.split("/")):
        return None
    base = folder.resolve()
    target = (base / name).resolve()
    if not target.is_relative_to(base) or not target.is_file():
        return None
    return target


def _uri_bytes(uri: Any, where: str, kind: str, folder: Path | None) -> int:
    if not isinstance(uri, str):
        raise _bad(kind, f"{where} must be a string")
    if uri.startswith("data:"):
        return _data_uri_bytes(uri, where, kind)
    if folder is None:
        raise MalformedMeshFileError(OUTSIDE_UPLOAD.format(where=where))
    target = external_file(uri, folder)
    if target is None:
        raise MalformedMeshFileError(
            f"the GLTF file's {where} refers to external buffer {uri[:80]!r}, which is not "
            "beside it (a file in the .gltf's own folder); keep the .bin files next to the "
            ".gltf, embed them, or use a .glb"
        )
    return target.stat().st_size


def _buffer_sizes(
    doc: dict[str, Any], kind: str, folder: Path | None, glb_bin: int | None
) -> list[int]:
    sizes = []
    for b, buf in enumerate(_list(doc, "buffers", kind)):
        where = f"buffers[{b}]"
        if "uri" in buf:
            real = _uri_bytes(buf["uri"], f"{where}.uri", kind, folder)
        elif b == 0 and glb_bin is not None:
            real = glb_bin
        else:
            raise _bad(kind, f"{where} has no uri and no binary chunk holds it")
        declared = buf.get("byteLength")
        if not _count(declared) or declared > real:
            raise _bad(kind, f"{where}.byteLength is {declared!r} but its data has {real} bytes")
        sizes.append(int(declared))
    for i, image in enumerate(_list(doc, "images", kind)):
        if "uri" in image:
            _uri_bytes(image["uri"], f"images[{i}].uri", kind, folder)
    return sizes


def _view_sizes(doc: dict[str, Any], kind: str, buffers: list[int]) -> list[tuple[int, int | None]]:
    views = []
    for v, view in enumerate(_list(doc, "bufferViews", kind)):
        where = f"bufferViews[{v}]"
        if not _index(view.get("buffer"), len(buffers)):
            raise _bad(kind, f"{where}.buffer names no buffer (there are {len(buffers)})")
        offset, length = view.get("byteOffset", 0), view.get("byteLength")
        if not _count(offset) or not _count(length) or offset + length > buffers[view["buffer"]]:
            raise _bad(
                kind,
                f"{where} spans bytes {offset!r} + {length!r} of a buffer of "
                f"{buffers[view['buffer']]} bytes",
            )
        stride = view.get("byteStride")
        if stride is not None and not (_count(stride) and 4 <= stride <= 252):
            raise _bad(kind, f"{where}.byteStride must be a whole number from 4 to 252")
        views.append((int(length), stride))
    return views


def _check_accessors(
    doc: dict[str, Any], kind: str, views: list[tuple[int, int | None]]
) -> list[int]:
    counts = []
    for a, acc in enumerate(_list(doc, "accessors", kind)):
        where = f"accessors[{a}]"
        count, ctype, atype = acc.get("count"), acc.get("componentType"), acc.get("type")
        if not _count(count) or ctype not in _COMPONENT_BYTES or atype not in _TYPE_COMPONENTS:
            raise _bad(kind, f"{where} needs a count, a componentType and a type")
        if "sparse" in acc:
            raise _bad(kind, f"{where} is sparse; sparse accessors are not supported")
        if not _index(acc.get("bufferView"), len(views)):
            raise _bad(kind, f"{where}.bufferView names no buffer view (there are {len(views)})")
        length, stride = views[acc["bufferView"]]
        element = _COMPONENT_BYTES[ctype] * _TYPE_COMPONENTS[atype]
        offset = acc.get("byteOffset", 0)
        if not _count(offset):
            raise _bad(kind, f"{where}.byteOffset must be a whole number of bytes")
        need = 0 if count == 0 else offset + (stride or element) * (count - 1) + element
        if need > length:
            raise _bad(
                kind,
                f"{where} declares {count} elements, {need} bytes, but its buffer view has {length}",
            )
        counts.append(int(count))
    return counts


def _check_no_cycle(parent: dict[int, int], n: int, kind: str) -> None:
    """Refuse a loop of parents, visiting each node once (linear in ``n``).

    With one parent each, a cycle is a loop of parents. Each walk up from a node
    stops at the first node an earlier walk settled, so a chain of ``n`` single
    children costs ``n`` steps in all (walking every node's ancestors anew cost
    ``n**2 / 2``: a 40,000-deep chain stalled validation, issue 30).
    """
    settled = bytearray(n)  # 0: not seen, 1: on the current walk, 2: has no loop above
    for i in range(n):
        path, j = [], i
        while not settled[j]:
            settled[j] = 1
            path.append(j)
            if j not in parent:
                break
            j = parent[j]
        else:
            if settled[j] == 1:
                raise _bad(kind, f"nodes[{j}] is its own ancestor; nodes must form trees")
        for k in path:
            settled[k] = 2


def _check_nodes(doc: dict[str, Any], kind: str, n_meshes: int) -> None:
    nodes = _list(doc, "nodes", kind)
    parent: dict[int, int] = {}
    for i, node in enumerate(nodes):
        children = node.get("children", [])
        if not isinstance(children, list) or not all(_index(c, len(nodes)) for c in children):
            raise _bad(kind, f"nodes[{i}].children must list existing nodes")
        for c in children:
            if c in parent or c == i:
                raise _bad(kind, f"node {c} has more than one parent; nodes must form trees")
            parent[c] = i
        if "mesh" in node and not _index(node["mesh"], n_meshes):
            raise _bad(kind, f"nodes[{i}].mesh names no mesh (there are {n_meshes})")
    _check_no_cycle(parent, len(nodes), kind)
    for s, scene in enumerate(_list(doc, "scenes", kind)):
        roots = scene.get("nodes", [])
        if not isinstance(roots, list) or not all(_index(r, len(nodes)) for r in roots):
            raise _bad(kind, f"scenes[{s}].nodes must list existing nodes")


def _check_meshes(doc: dict[str, Any], kind: str, counts: list[int], limits: MeshLimits) -> None:
    n_v = n_f = 0
    for m, mesh in enumerate(_list(doc, "meshes", kind)):
        prims = mesh.get("primitives", [])
        if not isinstance(prims, list) or not all(isinstance(p, dict) for p in prims):
            raise _bad(kind, f"meshes[{m}].primitives must be a list of objects")
        for p, prim in enumerate(prims):
            where = f"meshes[{m}].primitives[{p}]"
            attrs = prim.get("attributes", {})
            if not isinstance(attrs, dict) or not all(
                _index(x, len(counts)) for x in attrs.values()
            ):
                raise _bad(kind, f"{where}.attributes must name existing accessors")
            if "indices" in prim and not _index(prim["indices"], len(counts)):
                raise _bad(kind, f"{where}.indices names no accessor (there are {len(counts)})")
            accessors = doc["accessors"]
            if "POSITION" in attrs:
                position = accessors[attrs["POSITION"]]
                if (position["type"], position["componentType"]) != ("VEC3", 5126):
                    raise _bad(kind, f"{where}.attributes.POSITION must be a VEC3 of floats")
                n_v += counts[attrs["POSITION"]]
            if "indices" in prim:
                index = accessors[prim["indices"]]
                if index["type"] != "SCALAR" or index["componentType"] not in _INDEX_TYPES:
                    raise _bad(kind, f"{where}.indices must be a SCALAR of unsigned integers")
                n_f += counts[prim["indices"]] // 3
    limits.check(f"{kind} file", n_v, n_f)


def check_gltf_document(
    text: bytes,
    kind: str,
    limits: MeshLimits,
    *,
    folder: Path | None = None,
    glb_bin: int | None = None,
) -> None:
    """Check a glTF JSON document against the bytes behind it.

    Parameters
    ----------
    text : bytes
        The JSON document (a ``.gltf`` file, or a GLB's JSON chunk).
    kind : str
        ``"GLTF"`` or ``"GLB"``, for messages.
    limits : MeshLimits
    folder : Path, optional
        The folder of a ``.gltf`` read from disk, where its external buffers
        may lie; None (an upload) refuses every URI but ``data:`` ones, all
        with the same message.
    glb_bin : int, optional
        Size of the GLB's binary chunk (buffer 0 without a URI).

    Raises
    ------
    MalformedMeshFileError
        Invalid UTF-8 or JSON, nesting deeper than ``MAX_GLTF_JSON_DEPTH``,
        a byte length, offset or count that passes the data behind it, an
        index naming nothing, nodes that do not form trees, a reference
        outside the upload (one message for all).
    MeshTooLargeError
        More vertices or faces declared than ``limits``.
    """
    try:
        source = text.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _bad(kind, f"its JSON is not UTF-8 text (byte {exc.start})") from None
    depth = json_depth(source)
    if depth > MAX_GLTF_JSON_DEPTH:
        raise _bad(
            kind, f"its JSON is nested {depth} levels deep; at most {MAX_GLTF_JSON_DEPTH} are read"
        )
    try:
        doc = json.loads(source)
    except (ValueError, RecursionError) as exc:
        where = (
            f" (line {exc.lineno}, column {exc.colno})"
            if isinstance(exc, json.JSONDecodeError)
            else ""
        )
        raise _bad(kind, f"it is not valid JSON{where}") from None
    if not isinstance(doc, dict):
        raise _bad(kind, "the document must be a JSON object")
    views = _view_sizes(doc, kind, _buffer_sizes(doc, kind, folder, glb_bin))
    counts = _check_accessors(doc, kind, views)
    _check_meshes(doc, kind, counts, limits)
    _check_nodes(doc, kind, len(_list(doc, "meshes", kind)))


def check_glb(data: bytes, limits: MeshLimits) -> None:
    """Check a GLB container: header, chunk lengths, then its JSON document.

    Parameters
    ----------
    data : bytes
    limits : MeshLimits

    Raises
    ------
    MalformedMeshFileError
        A missing or wrong header, a declared length other than the file's,
        a chunk that runs past the end, no JSON chunk first, and whatever
        :func:`check_gltf_document` refuses.
    MeshTooLargeError
        More vertices or faces declared than ``limits``.
    """
    if len(data) < 20 or data[:4] != _GLB_MAGIC:
        raise _bad("GLB", "it does not start with a GLB header ('glTF', version, length)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise _bad("GLB", f"version {version}; only glTF 2 is read")
    if length != len(data):
        raise _bad("GLB", f"its header declares {length} bytes but the file has {len(data)}")
    chunks: list[tuple[int, int, int]] = []  # (type, start, length)
    pos = 12
    while pos + 8 <= len(data):
        size, ctype = struct.unpack_from("<II", data, pos)
        if pos + 8 + size > len(data):
            raise _bad(
                "GLB", f"chunk {len(chunks)} declares {size} bytes but {len(data) - pos - 8} remain"
            )
        chunks.append((ctype, pos + 8, size))
        pos += 8 + size
    if not chunks or chunks[0][0] != _JSON_CHUNK:
        raise _bad("GLB", "its first chunk must be the JSON chunk")
    _, start, size = chunks[0]
    binary = [c for c in chunks[1:] if c[0] == _BIN_CHUNK]
    check_gltf_document(
        data[start : start + size], "GLB", limits, glb_bin=binary[0][2] if binary else None
    )
