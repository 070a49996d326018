"""Stage 1 of a key through the key cache: each mesh's work done once, reused by every
morph of the same bytes with the same options.

A :class:`KeyArtifactStore` holds :class:`~conformorph.pipelines.face_morph.key_artifact.KeyArtifact`
archives by key: :class:`DirectoryArtifactStore` on disk for the CLI (``--cache DIR``), the
worker's job storage for the service. :func:`prepare_key_cached` finds a key's artifact
(or computes and stores it) and adds the per-pair part, the landmarks.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from conformorph.pipelines.face_morph.key_artifact import (
    CorruptArtifactError,
    KeyArtifact,
    artifact_bytes,
    artifact_from_bytes,
    cacheable,
    file_digest,
    key_artifact_key,
)
from conformorph.pipelines.face_morph.key_landmarks import (
    key_landmark_arrays,
    landmark_vertex_ids,
    translated_entries,
)
from conformorph.pipelines.face_morph.options import Arrays, KeyOptions

#: the name of the cache folder under the user's cache folder
CACHE_APP_DIR = "conformorph"


def default_cache_dir() -> Path:
    """``$XDG_CACHE_HOME/conformorph``, else ``~/.cache/conformorph`` (the CLI's default)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / CACHE_APP_DIR


class KeyArtifactStore(Protocol):
    """Where key artifacts live: bytes by key."""

    def get(self, key: str) -> bytes | None:
        """The bytes stored under ``key``, or None."""

    def put(self, key: str, data: bytes) -> None:
        """Store ``data`` under ``key`` (replacing it whole: readers see old or new)."""


class DirectoryArtifactStore:
    """Key artifacts as ``DIR/<key>.npz`` files, written atomically (a temporary file in
    the same folder, then :func:`os.replace`), so concurrent writers of one key leave
    one whole archive and a reader never sees half of one.

    Parameters
    ----------
    root : path
        The folder (created on the first write).
    """

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    def path(self, key: str) -> Path:
        """The file of ``key``."""
        if not key.isalnum():
            raise ValueError(f"a key artifact's key is hex digits, got {key!r}")
        return self.root / f"{key}.npz"

    def get(self, key: str) -> bytes | None:
        try:
            return self.path(key).read_bytes()
        except FileNotFoundError:
            return None

    def put(self, key: str, data: bytes) -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}.", suffix=".tmp", dir=self.root)
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
            os.replace(tmp, self.path(key))
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise


def compute_key_artifact(
    V: Any,
    F: Any,
    entries: list[Any],
    mesh_index: int,
    mesh_path: str | Path,
    key: str,
    *,
    file_type: str | None = None,
    options: KeyOptions | None = None,
) -> KeyArtifact:
    """A key's per-mesh work: vertex colours, preparation (``prepare="auto"``), surface.

    Parameters
    ----------
    V : (n0, 3) float64
    F : (m0, 3) int64
        The key as read from ``mesh_path``.
    entries : list
        Its landmark entries: only where a face cut places the face (recorded in
        ``face_cut_ids``, the artifact then serving only those landmarks).
    mesh_index : int
    mesh_path : path
        For the file's vertex colours.
    key : str
        :func:`key_artifact_key` of the inputs.
    file_type : str, optional
    options : KeyOptions, optional (default ``KeyOptions()``)

    Raises
    ------
    UnpreparableMeshError, MeshError, FoldedMapError
        As :func:`~conformorph.pipelines.face_morph.key_preparation.prepare_key_file`.
    """
    from conformorph.pipelines.face_morph.key_preparation import key_surface
    from conformorph.pipelines.face_morph.textures import read_vertex_colors
    from conformorph.pipelines.preparation import (
        PrepareOptions,
        UnpreparableMeshError,
        prepare_mesh_arrays,
        vertex_values,
    )

    options = KeyOptions() if options is None else options
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    colors = read_vertex_colors(mesh_path, V.shape[0], file_type=file_type)
    prepared, extra = None, {}
    if options.prepare == "auto":
        ids = landmark_vertex_ids(entries, V)
        prepared = prepare_mesh_arrays(
            V, F, PrepareOptions(vertex_budget=options.vertex_budget), landmark_ids=ids
        )
        if not prepared.report["disk"]:
            raise UnpreparableMeshError(
                f"mesh {mesh_index}: still not a disk after preparation: "
                f"{prepared.report['problem']}"
            )
        if prepared.changed:
            extra = {
                "input_V": V,
                "vertex_map": prepared.vertex_map,
                "merged_into": prepared.merged_into,
            }
            if colors is not None:
                colors = np.clip(vertex_values(prepared, colors), 0.0, 1.0)
            V, F = prepared.V, prepared.F
        if "face_cut" in prepared.report:
            extra["face_cut_ids"] = np.zeros(0, np.int64) if ids is None else ids
    s = key_surface(V, F, mesh_index=mesh_index, disk_method=options.disk_method)
    meta = s.pop("meta")
    return KeyArtifact(
        key=key,
        norm_scale=float(s.pop("norm_scale")),
        meta=meta,
        preparation=None if prepared is None else prepared.report,
        colors=colors,
        **s,
        **extra,
    )


def _serves(a: KeyArtifact, entries: list[Any]) -> bool:
    """Whether ``a`` holds for these landmark entries: always, unless a face cut placed
    by other landmarks made it."""
    if a.face_cut_ids is None:
        return True
    if a.input_V is None:  # never written so (a face cut changes the mesh): recompute
        return False
    ids = landmark_vertex_ids(entries, a.input_V)
    got = np.zeros(0, np.int64) if ids is None else ids
    return bool(np.array_equal(got, a.face_cut_ids))


def cached_artifact(
    store: KeyArtifactStore,
    mesh_path: str | Path,
    entries: list[Any],
    mesh_index: int,
    *,
    file_type: str | None = None,
    options: KeyOptions | None = None,
) -> tuple[KeyArtifact, dict[str, Any]]:
    """A key's artifact from ``store``, or computed from the file and stored.

    Returns
    -------
    artifact : KeyArtifact
    cache : dict
        ``key`` and ``state``: ``"hit"``, ``"stored"`` (computed, none was there),
        ``"replaced"`` (the stored one was unreadable: why, in ``detail``; or made
        for a face cut of other landmarks), and ``seconds``.
    """
    from conformorph.pipelines.mesh_io import read_mesh

    t0 = time.perf_counter()
    options = KeyOptions() if options is None else options
    ftype = file_type or Path(mesh_path).suffix.lstrip(".") or "obj"
    key = key_artifact_key(file_digest(mesh_path), ftype, options)
    info: dict[str, Any] = {"key": key, "state": "stored"}
    data = store.get(key)
    if data is not None:
        try:
            a = artifact_from_bytes(data, key)
        except CorruptArtifactError as exc:
            info.update(state="replaced", detail=str(exc))
        else:
            if _serves(a, entries):
                info.update(state="hit", seconds=time.perf_counter() - t0)
                return a, info
            info.update(state="replaced", detail="made for a face cut of other landmarks")
    V, F = read_mesh(mesh_path, file_type)
    a = compute_key_artifact(
        V, F, entries, mesh_index, mesh_path, key, file_type=file_type, options=options
    )
    store.put(key, artifact_bytes(a))
    info["seconds"] = time.perf_counter() - t0
    return a, info


def prepare_key_cached(
    store: KeyArtifactStore,
    mesh_path: str | Path,
    entries: list[Any],
    mesh_index: int,
    *,
    file_type: str | None = None,
    options: KeyOptions | None = None,
    confidence: list[float] | None = None,
) -> Arrays:
    """Stage 1 for one key file through ``store``: the same dict as
    :func:`~conformorph.pipelines.face_morph.key_preparation.prepare_key_file`
    (for keys :func:`cacheable` admits), plus ``meta["cache"]`` (see
    :func:`cached_artifact`).

    Parameters
    ----------
    store : KeyArtifactStore
    mesh_path : path
    entries : list
        The key's landmark entries (ids of the input's vertices or points).
    mesh_index : int
    file_type : str, optional
    options : KeyOptions, optional
    confidence : list of float, optional
        The landmarks' confidences, default 1.

    Raises
    ------
    LandmarkError
        Landmarks that do not resolve on the key (or sit on a removed vertex).
    UnpreparableMeshError, MeshError, FoldedMapError
        As :func:`~conformorph.pipelines.face_morph.key_preparation.prepare_key_file`.
    """
    a, info = cached_artifact(
        store, mesh_path, entries, mesh_index, file_type=file_type, options=options
    )
    prepared = a.prepared_mesh()
    if prepared is not None and a.input_V is not None:  # a changed key keeps its input
        entries = translated_entries(entries, a.input_V, prepared, mesh_index)
    conf = None if confidence is None else np.asarray(confidence, dtype=np.float64)
    out = key_landmark_arrays(a.surface(), entries, conf, mesh_index)
    if a.colors is not None:
        out["colors"] = a.colors
    if a.preparation is not None:
        out["meta"]["preparation"] = a.preparation
    if a.vertex_map is not None:
        out["prep_vertex_map"] = a.vertex_map
    out["meta"]["cache"] = info
    return out


__all__ = [
    "DirectoryArtifactStore",
    "KeyArtifactStore",
    "cacheable",
    "cached_artifact",
    "compute_key_artifact",
    "default_cache_dir",
    "prepare_key_cached",
]
