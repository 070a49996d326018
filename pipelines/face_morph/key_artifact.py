"""The per-mesh work of stage 1 as a record: what every morph of one key mesh shares.

Section 3 of the face paper splits into per-mesh work (preparation at the vertex
budget, the disk conformal map, H, Hn and the conformal factor λ) and per-pair work
(the landmarks on the surface and everything after). :class:`KeyArtifact` holds the
per-mesh part; :func:`artifact_bytes` and :func:`artifact_from_bytes` store it as an
``.npz`` archive (no pickle) under the key :func:`key_artifact_key` derives from the
mesh file's bytes and every option that changes the result.

The code version in the key is a SHA-256 of the source of every module the record
depends on (:func:`code_version`): chosen over a hand-bumped constant because a
forgotten bump would serve stale maps silently, while a needless miss only costs one
recomputation.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays, KeyOptions

#: the archive layout; bumped by hand when the fields of :class:`KeyArtifact` change
ARTIFACT_FORMAT = 1

#: the source folders and files (relative to the ``conformorph`` package) whose code
#: makes a key artifact: the geometry, the preparation, mesh reading, stage 1
_VERSIONED_SOURCES = (
    "geometry",
    "pipelines/preparation",
    "pipelines/mesh_file_checks",
    "pipelines/mesh_io.py",
    "pipelines/obj_arrays.py",
    "pipelines/face_morph/key_preparation.py",
    "pipelines/face_morph/key_artifact.py",
    "pipelines/face_morph/textures.py",
)

#: the surface arrays every artifact holds (see :func:`~conformorph.pipelines.face_morph.key_preparation.key_surface`)
_SURFACE = ("V", "F", "Vn", "uv", "lam", "H", "Hn", "norm_translation", "norm_scale")
_OPTIONAL = ("colors", "input_V", "vertex_map", "merged_into", "face_cut_ids")


class CorruptArtifactError(ValueError):
    """A stored key artifact that cannot be read back whole (truncated, altered,
    another key's, another layout)."""


@lru_cache(maxsize=1)
def code_version() -> str:
    """SHA-256 (hex) of the source of the modules a key artifact depends on.

    Returns
    -------
    str
        64 hex digits; changes with any edit of :data:`_VERSIONED_SOURCES`.
    """
    import conformorph

    root = Path(conformorph.__file__).resolve().parent
    h = hashlib.sha256()
    for rel in _VERSIONED_SOURCES:
        p = (root / rel).resolve()
        files = sorted(p.rglob("*.py")) if p.is_dir() else [p]
        for f in files:
            h.update(str(f.relative_to(p.parent)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def file_digest(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes, read in 1 MiB blocks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def key_artifact_key(mesh_sha256: str, file_type: str, options: KeyOptions) -> str:
    """The cache key of a key mesh's artifact: its bytes and what changes the result.

    Parameters
    ----------
    mesh_sha256 : str
        :func:`file_digest` of the mesh file.
    file_type : str
        How the file is parsed (``obj``, ``ply``, ...).
    options : KeyOptions
        ``prepare``, ``vertex_budget`` (with ``prepare="auto"`` only) and
        ``disk_method`` enter the key; the repairs (``fill_holes``, ``remove_ears``)
        are not cached (:func:`cacheable`).

    Returns
    -------
    str
        64 hex digits (SHA-256 of the JSON of all of it and :func:`code_version`).
    """
    payload = {
        "format": ARTIFACT_FORMAT,
        "code": code_version(),
        "mesh_sha256": mesh_sha256,
        "file_type": file_type.lower().lstrip("."),
        "prepare": options.prepare,
        "vertex_budget": options.vertex_budget if options.prepare == "auto" else None,
        "disk_method": options.disk_method,
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def cacheable(options: KeyOptions, texture: Any) -> str | None:
    """Why a key cannot use the cache, or None when it can.

    The legacy repairs (``fill_holes``, ``remove_ears``) rewrite the landmark ids per
    pair and a texture image is a second file the key does not cover: such keys are
    computed as before, and ``meta["cache"]`` says so.
    """
    if texture is not None:
        return "a texture image is not part of the key"
    if options.fill_holes or options.remove_ears:
        return "--fill-holes / --remove-ears are not cached (use --prepare auto)"
    return None


@dataclass(frozen=True)
class KeyArtifact:
    """One key mesh's per-mesh work (stage 1 without landmarks).

    Attributes
    ----------
    key : str
        :func:`key_artifact_key` of the inputs it was computed from.
    V : (n, 3) float64
    F : (m, 3) int64
        The key as the pipeline uses it (prepared when ``prepare="auto"``).
    Vn : (n, 3) float64
        ``V`` normalised by its diameter.
    uv : (n, 2) float64
        The harmonic disk conformal map.
    lam : (n,) float64
        The conformal factor λ (eq. 3 of the face paper).
    H : (n,) float64
    Hn : (n, 3) float64
        Mean curvature and mean-curvature vector of ``Vn``.
    norm_translation : (3,) float64
    norm_scale : float
        The normalisation ``Vn = (V - t) / s``.
    meta : dict
        The surface's diagnostics (JSON).
    preparation : dict or None
        The preparation report (``prepare="auto"``).
    colors : (n, 3) float64 or None
        The file's vertex colours on the key.
    input_V : (n0, 3) float64 or None
        The vertices as read, when the preparation changed the mesh (landmark ids of
        the input are carried over with them).
    vertex_map : (n,) int64 or None
        Input row of every key vertex (-1 added), when the preparation changed it.
    merged_into : (n0,) int64 or None
        :attr:`PreparedMesh.merged_into` (decimated keys).
    face_cut_ids : (k,) int64 or None
        The input landmark vertex ids that placed the face cut; None when no face
        cut ran (the artifact then serves any landmarks).
    """

    key: str
    V: NDArray[np.float64]
    F: NDArray[np.int64]
    Vn: NDArray[np.float64]
    uv: NDArray[np.float64]
    lam: NDArray[np.float64]
    H: NDArray[np.float64]
    Hn: NDArray[np.float64]
    norm_translation: NDArray[np.float64]
    norm_scale: float
    meta: dict[str, Any] = field(default_factory=dict)
    preparation: dict[str, Any] | None = None
    colors: NDArray[np.float64] | None = None
    input_V: NDArray[np.float64] | None = None
    vertex_map: NDArray[np.int64] | None = None
    merged_into: NDArray[np.int64] | None = None
    face_cut_ids: NDArray[np.int64] | None = None

    def surface(self) -> Arrays:
        """:func:`~conformorph.pipelines.face_morph.key_preparation.key_surface`'s dict (arrays shared, ``meta`` copied)."""
        out: Arrays = {k: getattr(self, k) for k in _SURFACE}
        out["norm_scale"] = np.array(self.norm_scale)
        out["meta"] = json.loads(json.dumps(self.meta))
        return out

    def prepared_mesh(self) -> Any:
        """The :class:`PreparedMesh` of a key the preparation changed, else None."""
        if self.vertex_map is None or self.preparation is None:
            return None
        from conformorph.pipelines.preparation.prepare import PreparedMesh

        return PreparedMesh(self.V, self.F, self.vertex_map, self.preparation, self.merged_into)


def artifact_bytes(a: KeyArtifact) -> bytes:
    """``a`` as an ``.npz`` archive (uncompressed; JSON for the dicts; no pickle)."""
    arrays: dict[str, NDArray[Any]] = {k: np.asarray(getattr(a, k)) for k in _SURFACE}
    for k in _OPTIONAL:
        if getattr(a, k) is not None:
            arrays[k] = np.asarray(getattr(a, k))
    arrays["header_json"] = np.array(
        json.dumps(
            {
                "format": ARTIFACT_FORMAT,
                "key": a.key,
                "meta": a.meta,
                "preparation": a.preparation,
            }
        )
    )
    buf = io.BytesIO()
    np.savez(buf, **arrays)  # type: ignore[arg-type]
    return buf.getvalue()


def artifact_from_bytes(data: bytes, key: str) -> KeyArtifact:
    """Read an artifact written by :func:`artifact_bytes`, checked whole.

    Parameters
    ----------
    data : bytes
    key : str
        The key it was looked up under: an archive of another key is refused.

    Raises
    ------
    CorruptArtifactError
        Truncated or altered bytes (the archive's CRCs), another key or layout,
        arrays missing or of inconsistent shapes.
    """
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
        header = json.loads(str(d.pop("header_json")))
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise CorruptArtifactError(f"unreadable key artifact: {exc}") from exc
    if header.get("format") != ARTIFACT_FORMAT or header.get("key") != key:
        raise CorruptArtifactError("key artifact of another key or layout")
    missing = [k for k in _SURFACE if k not in d]
    if missing:
        raise CorruptArtifactError(f"key artifact lacks {missing}")
    n = d["V"].shape[0]
    per_vertex = ("Vn", "uv", "lam", "H", "Hn", "colors", "vertex_map")
    if d["V"].shape != (n, 3) or any(k in d and d[k].shape[0] != n for k in per_vertex):
        raise CorruptArtifactError("key artifact arrays disagree on the vertex count")
    if ("vertex_map" in d or "face_cut_ids" in d) and "input_V" not in d:
        raise CorruptArtifactError("key artifact of a changed key lacks its input vertices")
    return KeyArtifact(
        key=key,
        V=d["V"],
        F=d["F"],
        Vn=d["Vn"],
        uv=d["uv"],
        lam=d["lam"],
        H=d["H"],
        Hn=d["Hn"],
        norm_translation=d["norm_translation"],
        norm_scale=float(d["norm_scale"]),
        meta=header["meta"],
        preparation=header["preparation"],
        **{k: d.get(k) for k in _OPTIONAL},
    )
