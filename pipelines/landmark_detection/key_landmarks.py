"""Automatic landmarks for a morph's key meshes (``--landmarks auto``, ``"landmarks": "auto"``).

:func:`detect_key_landmarks` runs :func:`~conformorph.pipelines.landmark_detection.detect.detect_landmarks`
on every key mesh, as read (the ids in the document index the meshes as
:func:`conformorph.pipelines.mesh_io.read_mesh` gives them), and returns the landmark file
document of :mod:`.landmark_file`: the surface points under ``landmarks``
(what the morph reads; points, so that the morph's own repairs, which renumber
vertices, do not move them), vertex ids, confidences and warnings.
:func:`landmark_report` is the summary the morph's ``metrics.json`` carries.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.landmark_detection.detection_errors import LandmarkDetectionError

Mesh = tuple[NDArray[np.float64], NDArray[np.int64]]


class LandmarkDetectionUnavailableError(ValueError):
    """mediapipe==0.10.14 or embreex is not installed where the detection runs."""

    code = "landmark_detection_unavailable"


def detect_key_landmarks(
    meshes: Sequence[Mesh], names: Sequence[str], options: Any = None, *, models: Any = None
) -> dict[str, Any]:
    """The landmark file document of key meshes, in input order.

    Parameters
    ----------
    meshes : sequence of ((n_i, 3) float64, (m_i, 3) int64)
        Key meshes as read.
    names : sequence of str
        One name per mesh (file names or mesh ids), stored under ``meshes`` and used
        in error messages.
    options : DetectionOptions, optional
    models : MediaPipeFaceModels, optional
        Loaded models (default: loaded once per process).

    Returns
    -------
    dict
        See :mod:`conformorph.pipelines.landmark_detection.landmark_file`.

    Raises
    ------
    LandmarkDetectionError
        A named failure (no face, a view from behind, a low score, a face too small in the
        render, rays lost) on one mesh: its message starts with the mesh's name and the
        exception carries ``mesh_index``.
    LandmarkDetectionUnavailableError
        mediapipe or embreex is not installed.
    ValueError
        ``meshes`` and ``names`` differ in length, or no mesh is given.
    """
    if len(meshes) != len(names):
        raise ValueError(f"{len(meshes)} meshes but {len(names)} names")
    if not meshes:
        raise ValueError("no mesh to detect landmarks on")
    try:
        from conformorph.pipelines.landmark_detection.detect import detect_landmarks, shared_models
        from conformorph.pipelines.landmark_detection.landmark_file import landmark_file_document
        from conformorph.pipelines.landmark_detection.multipie68 import TABLE_PATH

        models = models or shared_models()
    except ImportError as exc:
        raise LandmarkDetectionUnavailableError(str(exc)) from exc
    results = []
    for i, ((V, F), name) in enumerate(zip(meshes, names, strict=True)):
        try:
            results.append(detect_landmarks(V, F, options, models=models))
        except LandmarkDetectionError as exc:
            named = type(exc)(f"{name}: {exc}")
            named.mesh_index = i  # type: ignore[attr-defined]
            raise named from exc
        except ImportError as exc:  # embreex missing
            raise LandmarkDetectionUnavailableError(str(exc)) from exc
    detector = {
        "name": "mediapipe-facemesh",
        "version": models.version,
        "table": TABLE_PATH.name,
        "model_load_seconds": round(float(models.load_seconds), 3),
        "seconds": [round(r.seconds, 3) for r in results],
    }
    return landmark_file_document(results, list(names), detector)


def landmark_report(document: dict[str, Any], file_name: str = "landmarks.json") -> dict[str, Any]:
    """The ``landmarks`` entry of a morph's ``metrics.json`` for detected landmarks.

    Parameters
    ----------
    document : dict
        A document of :func:`detect_key_landmarks`.
    file_name : str
        Where the document was written, beside the outputs.

    Returns
    -------
    dict
        ``source`` ("auto"), ``file``, per mesh ``score``, ``min_confidence``,
        ``low_confidence`` (indices below 0.5) and ``warnings``; ``warnings`` flat too,
        each prefixed with its mesh.
    """
    conf = [np.asarray(c, dtype=np.float64) for c in document["confidence"]]
    per_mesh = [
        {
            "mesh": name,
            "score": score,
            "min_confidence": round(float(c.min()), 4) if c.size else None,
            "low_confidence": np.flatnonzero(c < 0.5).tolist(),
            "warnings": list(w),
        }
        for name, score, c, w in zip(
            document["meshes"], document["detector"]["score"], conf, document["warnings"],
            strict=True,
        )
    ]
    flat = [f"{m['mesh']}: {w}" for m in per_mesh for w in m["warnings"]]
    return {"source": "auto", "file": file_name, "meshes": per_mesh, "warnings": flat}
