"""PLY files (ASCII and binary) checked against their header before trimesh reads them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from conformorph.geometry.mesh_errors import NotTrianglesError

from .errors import MalformedMeshFileError, MeshLimits, corner_problem, shown

#: PLY scalar types as numpy dtype codes
PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
#: names of the face element's vertex index list in files seen in the wild
INDEX_NAMES = ("vertex_indices", "vertex_index")
_FORMATS = ("ascii", "binary_little_endian", "binary_big_endian")


def _bad(message: str) -> MalformedMeshFileError:
    return MalformedMeshFileError(f"the PLY file is malformed: {message}")


@dataclass
class PlyProperty:
    """One property: its name, the list-count type (None for a scalar) and the item type."""

    name: str
    count_type: str | None
    item_type: str


@dataclass
class PlyElement:
    """One element of the header: name, declared record count, properties."""

    name: str
    count: int
    props: list[PlyProperty] = field(default_factory=list)

    def min_record_bytes(self) -> int:
        """Bytes of the smallest binary record (every list empty)."""
        return sum(np.dtype(p.count_type or p.item_type).itemsize for p in self.props)

    def is_index_list(self, prop: PlyProperty) -> bool:
        return self.name == "face" and prop.name in INDEX_NAMES


def _property(words: list[str], lineno: int) -> PlyProperty:
    if words[1] == "list":
        if len(words) != 5 or words[2] not in PLY_TYPES or words[3] not in PLY_TYPES:
            raise _bad(f"header line {lineno}: expected 'property list <count type> <type> <name>'")
        if PLY_TYPES[words[2]][0] == "f":
            raise _bad(f"header line {lineno}: a list's count type must be an integer type")
        return PlyProperty(words[4], PLY_TYPES[words[2]], PLY_TYPES[words[3]])
    if len(words) != 3 or words[1] not in PLY_TYPES:
        raise _bad(
            f"header line {lineno}: expected 'property <type> <name>', got {shown(' '.join(words))}"
        )
    return PlyProperty(words[2], None, PLY_TYPES[words[1]])


def parse_ply_header(data: bytes) -> tuple[str, list[PlyElement], int]:
    """The format, the elements and the offset where the body starts.

    Raises
    ------
    MalformedMeshFileError
        No ``end_header``, a header that is not ASCII, an unknown format or
        type, a count that is not a whole number, a property before any
        element, an element with records but no properties.
    """
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise _bad("it must start with 'ply' and have an 'end_header' line")
    try:
        header = data[:end].decode("ascii")
    except UnicodeDecodeError:
        raise _bad("the header is not ASCII text") from None
    fmt = ""
    elements: list[PlyElement] = []
    for lineno, line in enumerate(header.splitlines(), start=1):
        words = line.split()
        if words[:1] == ["format"]:
            fmt = words[1] if len(words) > 1 else ""
            if fmt not in _FORMATS:
                raise _bad(f"header line {lineno}: unknown format {shown(fmt)}")
        elif words[:1] == ["element"]:
            if len(words) != 3 or not words[2].isdigit():
                raise _bad(f"header line {lineno}: expected 'element <name> <count>'")
            elements.append(PlyElement(words[1], int(words[2])))
        elif words[:1] == ["property"]:
            if not elements or len(words) < 3:
                raise _bad(f"header line {lineno}: a property outside an element")
            elements[-1].props.append(_property(words, lineno))
    if not fmt:
        raise _bad("the header has no 'format' line")
    for el in elements:
        if el.count and not el.props:
            raise _bad(f"element {shown(el.name)} declares {el.count} records but no properties")
    newline = data.find(b"\n", end)
    return fmt, elements, len(data) if newline < 0 else newline + 1


def _list_count(word: bytes, where: str) -> int:
    try:
        return int(word)
    except ValueError:
        pass
    try:
        value = float(word)
    except ValueError:
        value = float("nan")
    if not value.is_integer():
        raise _bad(f"{where}: list length {shown(word)} is not a whole number")
    return int(value)


def _check_ascii_record(el: PlyElement, i: int, lineno: int, words: list[bytes]) -> None:
    where = f"line {lineno}"
    k = 0
    for prop in el.props:
        if k >= len(words):
            raise _bad(
                f"{where}: {el.name} {i} has fewer values than its {len(el.props)} properties"
            )
        if prop.count_type is None:
            k += 1
            continue
        n = _list_count(words[k], where)
        given = len(words) - k - 1
        if el.is_index_list(prop):
            if n < 0 or n > given:
                raise _bad(f"{where}: face {i} declares {n} corners but gives {given}")
            if n != 3:
                raise NotTrianglesError(
                    "the PLY file is not all triangles: " + corner_problem(f"{where}: ", i, n)
                )
        elif n < 0 or n > given:
            raise _bad(f"{where}: {el.name} {i} declares a list of {n} values but gives {given}")
        k += 1 + n


def _plain_ascii_records(el: PlyElement, records: list[tuple[int, list[bytes]]]) -> bool:
    """True when the records need no walk: scalars only, with enough values on every line,
    or triangles only (``3 i j k`` after the scalars, on every line)."""
    n_scalars = sum(p.count_type is None for p in el.props)
    if n_scalars == len(el.props):
        return all(len(w) >= n_scalars for _, w in records)
    last = el.props[-1]
    if n_scalars != len(el.props) - 1 or not el.is_index_list(last):
        return False
    return all(len(w) == n_scalars + 4 and w[n_scalars] == b"3" for _, w in records)


def _check_ascii(data: bytes, body: int, elements: list[PlyElement]) -> None:
    first_line = data[:body].count(b"\n") + 1
    rows = [
        (lineno, words)
        for lineno, raw in enumerate(data[body:].splitlines(), start=first_line)
        if (words := raw.split())
    ]
    declared = sum(el.count for el in elements)
    if declared > len(rows):
        counts = ", ".join(f"{el.count} {el.name}" for el in elements)
        raise _bad(
            f"the header declares {counts} records, one line each, but the body has {len(rows)} lines"
        )
    r = 0
    for el in elements:
        records = rows[r : r + el.count]
        if not _plain_ascii_records(el, records):  # slow path: find the first fault
            for i, (lineno, words) in enumerate(records):
                _check_ascii_record(el, i, lineno, words)
        r += el.count
        if el.name == "face":
            return


def _faces_of_triangles(data: bytes, pos: int, el: PlyElement, order: str) -> int | None:
    """Fast path for a face element whose one list is the index list: the end offset of the
    element when every face is a triangle (None when the element has another shape)."""
    lists = [p for p in el.props if p.count_type is not None]
    if len(lists) != 1 or not el.is_index_list(lists[0]):
        return None
    at = el.props.index(lists[0])
    prop = lists[0]
    count_type = prop.count_type or "u1"
    pre = sum(np.dtype(p.item_type).itemsize for p in el.props[:at])
    post = sum(np.dtype(p.item_type).itemsize for p in el.props[at + 1 :])
    cs = np.dtype(count_type).itemsize
    rec = pre + cs + 3 * np.dtype(prop.item_type).itemsize + post
    room = len(data) - pos - pre - cs  # bytes after the first count field
    fit = min(el.count, room // rec + 1) if room >= 0 else 0  # count fields present
    counts = np.ndarray((fit,), np.dtype(order + count_type), data, pos + pre, (rec,))
    bad = np.flatnonzero(counts != 3)
    if bad.size:
        j, n = int(bad[0]), int(counts[bad[0]])
        if n < 0:
            raise _bad(f"face {j} declares {n} corners")
        raise NotTrianglesError("the PLY file is not all triangles: " + corner_problem("", j, n))
    if pos + el.count * rec > len(data):
        raise _bad(
            f"the file ends inside face {(len(data) - pos) // rec}; the header declares "
            f"{el.count} faces"
        )
    return pos + el.count * rec


def _walk_binary_element(data: bytes, pos: int, el: PlyElement, order: str) -> int:
    """Walk the records of an element with lists; the offset where the element ends."""
    for i in range(el.count):
        for prop in el.props:
            if prop.count_type is None:
                pos += np.dtype(prop.item_type).itemsize
                continue
            cs = np.dtype(prop.count_type).itemsize
            if pos + cs > len(data):
                raise _bad(f"the file ends inside {el.name} {i}; the header declares {el.count}")
            n = int(np.frombuffer(data, order + prop.count_type, 1, pos)[0])
            if n < 0:
                raise _bad(f"{el.name} {i} declares a list of {n} values")
            if el.is_index_list(prop) and n != 3:
                raise NotTrianglesError(
                    "the PLY file is not all triangles: " + corner_problem("", i, n)
                )
            pos += cs + n * np.dtype(prop.item_type).itemsize
        if pos > len(data):
            raise _bad(f"the file ends inside {el.name} {i}; the header declares {el.count}")
    return pos


def _check_binary(data: bytes, body: int, elements: list[PlyElement], order: str) -> None:
    need = sum(el.count * el.min_record_bytes() for el in elements)
    if need > len(data) - body:
        counts = ", ".join(f"{el.count} {el.name}" for el in elements)
        raise _bad(
            f"the header declares {counts} records, at least {need} bytes, but the body has "
            f"{len(data) - body}"
        )
    pos = body
    for el in elements:
        if all(p.count_type is None for p in el.props):
            pos += el.count * el.min_record_bytes()
        else:
            end = _faces_of_triangles(data, pos, el, order)
            pos = _walk_binary_element(data, pos, el, order) if end is None else end
        if el.name == "face":
            return


def check_ply(data: bytes, limits: MeshLimits) -> tuple[int, int]:
    """Check a PLY file's records against its header; returns its declared (vertex, face) counts.

    Parameters
    ----------
    data : bytes
        The file, ASCII or binary.
    limits : MeshLimits

    Returns
    -------
    n_vertices, n_faces : int
        The counts of the ``vertex`` and ``face`` elements (0 when absent).

    Raises
    ------
    MalformedMeshFileError
        A malformed header (see :func:`parse_ply_header`), more records
        declared than the body can hold, a face that gives fewer corners
        than it declares, a list length that is not a whole number, a file
        that ends inside a record.
    NotTrianglesError
        A face with other than 3 corners (its 0-based number).
    MeshTooLargeError
        More vertices or faces declared than ``limits``.

    Notes
    -----
    Declared counts are checked against the body's size (bytes, or lines for
    ASCII) before any record is visited; every later loop advances through
    real bytes, so its cost follows the file's size, never a declared count.
    """
    fmt, elements, body = parse_ply_header(data)
    counts = {el.name: el.count for el in elements}
    limits.check("PLY file", counts.get("vertex", 0), counts.get("face", 0))
    if fmt == "ascii":
        _check_ascii(data, body, elements)
    else:
        _check_binary(data, body, elements, "<" if fmt == "binary_little_endian" else ">")
    return counts.get("vertex", 0), counts.get("face", 0)
