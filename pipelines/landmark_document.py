"""Landmark documents: layouts, counts and entries, in pure Python (no numpy).

The API checks uploaded landmark documents with this module (it must not load
numpy); :mod:`conformorph.pipelines.landmarks_io` builds on it to snap the entries to a mesh.

Accepted layouts (see :mod:`conformorph.pipelines.landmarks_io` for the shared-data files)::

    {"landmarks": [[12, 40, [0.1, 2.0, 3.5], ...], [...], ...]}   # one list per mesh
    {"landmarks_multipie68_0based": [...]}                        # one list for every mesh
    {"nearest_vertex_0based": [...]}                              # likewise
    {"face1": {"interior_landmarks_0based": [...],
               "boundary_landmarks_0based_per_loop": [[outer], [inner], ...]}, "face2": ...}

Every entry is a vertex index (an integer ≥ 0; a float with no fractional part
counts as one) or an ``[x, y, z]`` point of three finite numbers. Each error
names the offending place in the document, e.g. ``landmarks[1][4]``, in its
message and in its ``field`` attribute.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

#: keys of the shared-data files whose single id list applies to every mesh
SHARED_LIST_KEYS = ("landmarks_multipie68_0based", "nearest_vertex_0based")

#: a checked landmark: a vertex index or an [x, y, z] point
Landmark = int | list[float]


class LandmarkError(ValueError):
    """Base class of landmark-file errors (a ValueError: the CLI maps it to exit code 2).

    Parameters
    ----------
    message : str
    field : str, optional
        The place in the document, e.g. ``landmarks[1][4]`` (None: the document as a whole).
    """

    code = "landmark_error"

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class LandmarkCountMismatchError(LandmarkError):
    """The lists of landmarks differ in length, or their number differs from the meshes'."""

    code = "landmark_count_mismatch"


class LandmarkIndexError(LandmarkError):
    """A vertex index is out of range (or not an integer)."""

    code = "landmark_index_out_of_range"


class DuplicateLandmarkError(LandmarkError):
    """Two landmarks of one mesh are the same vertex or the same surface point."""

    code = "duplicate_landmarks"


class TooFewLandmarksError(LandmarkError):
    """Fewer than 3 landmarks per mesh."""

    code = "too_few_landmarks"


class LandmarkTooFarError(LandmarkError):
    """A point landmark is too far from the surface to be snapped."""

    code = "landmark_too_far"


class LandmarkFormatError(LandmarkError):
    """The file is not valid JSON or not in a recognised layout."""

    code = "landmark_format"


def _short(x: Any, limit: int = 60) -> str:
    r = repr(x)
    return r if len(r) <= limit else r[: limit - 3] + "..."


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def check_landmark_entry(entry: Any, field: str, *, label: str | None = None) -> Landmark:
    """One checked entry: a vertex index (int ≥ 0) or an ``[x, y, z]`` point (floats).

    Parameters
    ----------
    entry : object
        Parsed JSON.
    field : str
        Where the entry is, for the error (e.g. ``landmarks[0][2]``).
    label : str, optional
        How the error message names the entry (default ``field``).

    Returns
    -------
    int or list of 3 floats
        The index (a float such as ``4.0`` becomes ``4``) or the point.

    Raises
    ------
    LandmarkIndexError
        A negative index.
    LandmarkFormatError
        Anything else that is neither an index nor a finite point.
    """
    label = field if label is None else label
    if isinstance(entry, float) and math.isfinite(entry) and entry.is_integer():
        entry = int(entry)
    if isinstance(entry, int) and not isinstance(entry, bool):
        if entry < 0:
            raise LandmarkIndexError(f"{label}: vertex index {entry} is negative", field)
        return entry
    if (
        isinstance(entry, list)
        and len(entry) == 3
        and all(_is_number(c) and math.isfinite(c) for c in entry)
    ):
        return [float(c) for c in entry]
    raise LandmarkFormatError(
        f"{label}: expected a vertex index (an integer >= 0) or an [x, y, z] point of "
        f"three finite numbers, got {_short(entry)}",
        field,
    )


def _id_list(value: Any, field: str) -> list[tuple[Any, str]]:
    """The entries of a JSON list with their places; LandmarkFormatError when not a list."""
    if not isinstance(value, list):
        raise LandmarkFormatError(
            f"{field}: must be a list of landmarks, got {_short(value)}", field
        )
    return [(e, f"{field}[{j}]") for j, e in enumerate(value)]


def _face_keys(data: dict[str, Any]) -> list[str]:
    return sorted(
        (k for k in data if k.startswith("face") and isinstance(data[k], dict)),
        key=lambda k: (len(k), k),
    )


def document_mesh_count(data: Any) -> int | None:
    """How many meshes a landmark document is for (None: one list shared by any number).

    Parameters
    ----------
    data : object
        Parsed JSON (see :func:`parse_landmark_json` for the layouts).

    Returns
    -------
    int or None

    Raises
    ------
    LandmarkFormatError
        Not a JSON object in a known layout.
    """
    if not isinstance(data, dict):
        raise LandmarkFormatError("a landmark document must be a JSON object")
    if "landmarks" in data:
        lists = data["landmarks"]
        if not isinstance(lists, list):
            raise LandmarkFormatError(
                "landmarks: must be a list of lists, one per mesh", "landmarks"
            )
        return len(lists)
    if any(k in data for k in SHARED_LIST_KEYS):
        return None
    faces = _face_keys(data)
    if not faces:
        raise LandmarkFormatError(
            'no "landmarks" key (nor a known shared-data layout: '
            + ", ".join(SHARED_LIST_KEYS)
            + ", face1/face2/…)"
        )
    return len(faces)


def _located_lists(data: dict[str, Any], n_meshes: int) -> list[list[tuple[Any, str]]]:
    """One list per mesh of (entry, place in the document)."""
    if "landmarks" in data:
        lists = data["landmarks"]
        if not isinstance(lists, list):
            raise LandmarkFormatError(
                "landmarks: must be a list of lists, one per mesh", "landmarks"
            )
        return [_id_list(x, f"landmarks[{i}]") for i, x in enumerate(lists)]
    key = next((k for k in SHARED_LIST_KEYS if k in data), None)
    if key is not None:
        shared = _id_list(data[key], key)
        return [list(shared) for _ in range(n_meshes)]
    out = []
    for k in _face_keys(data):
        d = data[k]
        if "interior_landmarks_0based" not in d:
            raise LandmarkFormatError(f"{k}: lacks interior_landmarks_0based", k)
        ids = _id_list(d["interior_landmarks_0based"], f"{k}.interior_landmarks_0based")
        loops_field = f"{k}.boundary_landmarks_0based_per_loop"
        loops = d.get("boundary_landmarks_0based_per_loop", [])
        if not isinstance(loops, list):
            raise LandmarkFormatError(f"{loops_field}: must be a list of lists", loops_field)
        # inner loops only: the outer loop's landmarks sit on the disk map's unit circle
        for q, loop in enumerate(loops[1:], start=1):
            ids += _id_list(loop, f"{loops_field}[{q}]")
        out.append(ids)
    return out


def parse_landmark_json(data: Any, n_meshes: int) -> list[list[Landmark]]:
    """Normalise the accepted JSON layouts to one list of checked entries per mesh.

    Parameters
    ----------
    data : object
        Parsed JSON.
    n_meshes : int
        Number of input meshes.

    Returns
    -------
    list of n_meshes lists
        Each of the same length m ≥ 3, holding vertex indices (int) and
        ``[x, y, z]`` points (floats), see :func:`check_landmark_entry`.

    Raises
    ------
    LandmarkFormatError, LandmarkIndexError
        Not a known layout, or an entry that is neither an index nor a point
        (the error's ``field`` says where).
    LandmarkCountMismatchError, TooFewLandmarksError
        The wrong number of lists or of landmarks.
    """
    document_mesh_count(data)  # the layout check
    located = _located_lists(data, n_meshes)
    lists = [[check_landmark_entry(e, where) for e, where in lst] for lst in located]
    if not lists:
        raise LandmarkCountMismatchError("the landmark document holds no lists")
    if len(lists) != n_meshes:
        raise LandmarkCountMismatchError(
            f"the landmark file has {len(lists)} lists but {n_meshes} meshes were given"
        )
    counts = [len(x) for x in lists]
    if len(set(counts)) != 1:
        raise LandmarkCountMismatchError(
            f"every mesh needs the same number of landmarks, got {counts} (mesh order)"
        )
    if counts[0] < 3:
        raise TooFewLandmarksError(f"at least 3 landmarks per mesh are needed, got {counts[0]}")
    return lists


def read_landmark_file(path: str | Path, n_meshes: int) -> list[list[Landmark]]:
    """Read and parse a landmark file (see :func:`parse_landmark_json`)."""
    try:
        data = json.loads(Path(path).read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise LandmarkFormatError(f"{path}: not valid JSON: {exc}") from exc
    return parse_landmark_json(data, n_meshes)


def landmark_confidence(data: Any, n_meshes: int) -> list[list[float] | None]:
    """The optional per-point ``confidence`` of a landmark document, one list per mesh.

    ``conformorph landmarks`` writes one list of values in [0, 1] per mesh, as long as
    that mesh's landmarks; a document without the key gives ``None`` for every mesh.

    Raises
    ------
    LandmarkFormatError
        When the key is present but not one list of numbers in [0, 1] per mesh.
    """
    conf = data.get("confidence") if isinstance(data, dict) else None
    if conf is None:
        return [None] * n_meshes
    ok = isinstance(conf, list) and len(conf) == n_meshes
    ok = ok and all(
        isinstance(row, list)
        and all(
            isinstance(c, int | float) and not isinstance(c, bool) and 0.0 <= c <= 1.0 for c in row
        )
        for row in conf
    )
    if not ok:
        raise LandmarkFormatError(
            f"'confidence' must hold one list of numbers in [0, 1] per mesh ({n_meshes})"
        )
    return [[float(c) for c in row] for row in conf]


def read_landmark_confidence(path: str | Path, n_meshes: int) -> list[list[float] | None]:
    """The per-point confidence of a landmark file, if any (:func:`landmark_confidence`)."""
    try:
        data = json.loads(Path(path).read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise LandmarkFormatError(f"{path}: not valid JSON: {exc}") from exc
    return landmark_confidence(data, n_meshes)


#: where a given landmark came from (the viewer says so in the morph's landmark_provenance)
PROVENANCES = ("detected", "moved", "picked", "file")


def landmark_provenance_report(
    provenance: list[list[str]], fit: str | None, mesh_names: list[str] | None = None
) -> dict[str, Any]:
    """The ``landmarks`` entry of a morph's ``metrics.json`` for landmarks a request gave.

    Parameters
    ----------
    provenance : list of list of str
        Per mesh, per landmark: one of :data:`PROVENANCES`.
    fit : str or None
        The landmark fit the registration used ("exact" or "tolerant").
    mesh_names : list of str, optional
        The meshes' file names, in order.

    Returns
    -------
    dict
        ``source`` ("request"), ``fit``, totals per provenance (``counts``) and per mesh
        ``counts`` and ``moved``/``picked``: the landmarks a person placed, as 0-based
        indices into the landmark lists (JSON arrays index from 0; a person reads
        landmark ``i + 1``).
    """
    totals = dict.fromkeys(PROVENANCES, 0)
    per_mesh = []
    for k, marks in enumerate(provenance):
        counts = {p: sum(1 for m in marks if m == p) for p in PROVENANCES}
        for p, c in counts.items():
            totals[p] += c
        row: dict[str, Any] = {"counts": {p: c for p, c in counts.items() if c}}
        if mesh_names is not None and k < len(mesh_names):
            row = {"mesh": mesh_names[k], **row}
        for p in ("moved", "picked"):
            if counts[p]:
                row[p] = [i for i, m in enumerate(marks) if m == p]
        per_mesh.append(row)
    return {
        "source": "request",
        "fit": fit,
        "counts": {p: c for p, c in totals.items() if c},
        "meshes": per_mesh,
    }
