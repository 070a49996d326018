"""Detected landmarks through the key cache (``conformorph morph --landmarks auto``): each
mesh's detection done once, found again for the same bytes, detection options, detector
code and mediapipe version.

A mesh's entry is its part of the landmark file document (points, vertex ids, triangles,
barycentric coordinates, confidences, warnings, score, detector version) as JSON in an
``.npz`` archive (no pickle), under :func:`detection_key`. When every mesh is found, the
detector's models are not even loaded.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from collections.abc import Sequence
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from conformorph.pipelines.face_morph.key_artifact import CorruptArtifactError, file_digest
from conformorph.pipelines.face_morph.key_cache import KeyArtifactStore

#: the per-mesh fields of a landmark file document (lists indexed by mesh)
PER_MESH = ("landmarks", "vertex_ids", "triangles", "barycentric", "confidence", "warnings")


@lru_cache(maxsize=1)
def detection_code_version() -> str:
    """SHA-256 (hex) of the detection package's source and its 478 → 68 table, and the
    installed mediapipe's version."""
    from importlib import metadata

    import conformorph.pipelines.landmark_detection as pkg

    h = hashlib.sha256()
    for f in sorted(Path(pkg.__file__).resolve().parent.iterdir()):
        if f.suffix in (".py", ".json"):
            h.update(f.name.encode())
            h.update(f.read_bytes())
    try:
        h.update(metadata.version("mediapipe").encode())
    except metadata.PackageNotFoundError:
        h.update(b"no mediapipe")
    return h.hexdigest()


def detection_key(mesh_sha256: str, options: Any) -> str:
    """The cache key of one mesh's detection: its bytes, the :class:`DetectionOptions`
    (all fields) and :func:`detection_code_version`."""
    from conformorph.pipelines.landmark_detection.detect import DetectionOptions

    opts = asdict(options or DetectionOptions())
    payload = {
        "kind": "landmarks68",
        "mesh_sha256": mesh_sha256,
        "options": opts,
        "code": detection_code_version(),
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()


def _entry_bytes(entry: dict[str, Any], key: str) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, entry_json=np.array(json.dumps({"key": key, "entry": entry})))
    return buf.getvalue()


def _entry_from_bytes(data: bytes, key: str) -> dict[str, Any]:
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            got = json.loads(str(z["entry_json"]))
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise CorruptArtifactError(f"unreadable landmark entry: {exc}") from exc
    if not isinstance(got, dict) or got.get("key") != key:
        raise CorruptArtifactError("landmark entry of another key")
    entry = got.get("entry")
    if not isinstance(entry, dict) or any(k not in entry for k in (*PER_MESH, "score")):
        raise CorruptArtifactError("landmark entry lacks fields")
    return entry


def cached_detection_document(
    mesh_paths: Sequence[str | Path], store: KeyArtifactStore, options: Any = None
) -> dict[str, Any]:
    """The landmark file document of ``mesh_paths``
    (:func:`~conformorph.pipelines.landmark_detection.key_landmarks.detect_key_landmarks`'s),
    each mesh's entry from ``store`` or detected and stored.

    Parameters
    ----------
    mesh_paths : sequence of paths
    store : KeyArtifactStore
    options : DetectionOptions, optional

    Returns
    -------
    dict
        The document; ``detector.cache`` lists each mesh's ``hit``/``stored``/``replaced``,
        and ``detector.model_load_seconds`` is 0 when no model was loaded.

    Raises
    ------
    LandmarkDetectionError, LandmarkDetectionUnavailableError
        As ``detect_key_landmarks`` (``mesh_index`` the position in ``mesh_paths``).
    """
    from conformorph.pipelines.landmark_detection.key_landmarks import detect_key_landmarks
    from conformorph.pipelines.landmark_detection.multipie68 import TABLE_PATH
    from conformorph.pipelines.mesh_io import read_mesh

    names = [str(p) for p in mesh_paths]
    keys = [detection_key(file_digest(p), options) for p in mesh_paths]
    entries: list[dict[str, Any] | None] = []
    states: list[str] = []
    for key in keys:
        data = store.get(key)
        try:
            entries.append(None if data is None else _entry_from_bytes(data, key))
            states.append("stored" if data is None else "hit")
        except CorruptArtifactError:
            entries.append(None)
            states.append("replaced")
    missing = [i for i, e in enumerate(entries) if e is None]
    detector: dict[str, Any] = {"model_load_seconds": 0.0}
    if missing:
        try:
            doc = detect_key_landmarks(
                [read_mesh(mesh_paths[i]) for i in missing], [names[i] for i in missing], options
            )
        except ValueError as exc:  # the failing mesh's index among all of them
            if hasattr(exc, "mesh_index"):
                exc.mesh_index = missing[int(exc.mesh_index)]
            raise
        detector = {k: v for k, v in doc["detector"].items() if k not in ("score", "seconds")}
        for j, i in enumerate(missing):
            entry = {k: doc[k][j] for k in PER_MESH}
            entry.update(
                score=doc["detector"]["score"][j],
                seconds=doc["detector"]["seconds"][j],
                version=doc["detector"]["version"],
            )
            store.put(keys[i], _entry_bytes(entry, keys[i]))
            entries[i] = entry
    got = [e for e in entries if e is not None]
    out: dict[str, Any] = {k: [e[k] for e in got] for k in PER_MESH}
    out["layout"] = "multipie68_0based"
    out["meshes"] = names
    out["detector"] = {
        "name": "mediapipe-facemesh",
        "version": got[0].get("version", "unknown"),
        "table": TABLE_PATH.name,
        **detector,
        "seconds": [
            e.get("seconds", 0.0) if s != "hit" else 0.0 for e, s in zip(got, states, strict=True)
        ],
        "score": [e["score"] for e in got],
        "cache": states,
    }
    return out
