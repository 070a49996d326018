"""``conformorph morph … --landmarks auto``: detect the key meshes' landmarks, then morph.

:func:`write_detected_landmarks` detects the 68 Multi-PIE landmarks on every key
mesh as read (:func:`conformorph.pipelines.landmark_detection.key_landmarks.detect_key_landmarks`)
and writes them to ``OUTDIR/landmarks.json``, in the layout ``--landmarks`` reads,
with confidences and warnings, so that a person can check or edit the file and pass
it back. :func:`run_face_morph_auto` morphs with that file and adds the detection's
report (warnings, lowest confidences) to ``metrics.json`` under ``landmarks``.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from conformorph.pipelines.face_morph.options import FaceMorphOptions, ProgressFn

#: the file beside the outputs
LANDMARK_FILE = "landmarks.json"


def write_detected_landmarks(
    mesh_paths: Sequence[str | Path],
    outdir: str | Path,
    detection: Any = None,
    *,
    cache: str | Path | None = None,
) -> tuple[Path, dict[str, Any]]:
    """Detect the landmarks of every key mesh and write ``outdir/landmarks.json``.

    Parameters
    ----------
    mesh_paths : sequence of paths
        Key meshes, read with :func:`conformorph.pipelines.mesh_io.read_mesh`.
    outdir : path
        Created if missing.
    detection : DetectionOptions, optional
    cache : path, optional
        The key cache folder: each mesh's detection is looked up there and stored
        (:func:`~conformorph.pipelines.face_morph.landmark_cache.cached_detection_document`).

    Returns
    -------
    path : Path
        The landmark file written.
    report : dict
        :func:`~conformorph.pipelines.landmark_detection.key_landmarks.landmark_report` of it.

    Raises
    ------
    LandmarkDetectionError, LandmarkDetectionUnavailableError
        Named failures (ValueErrors), the mesh's path first in the message.
    """
    from conformorph.pipelines.landmark_detection.key_landmarks import (
        detect_key_landmarks,
        landmark_report,
    )
    from conformorph.pipelines.mesh_io import read_mesh

    if cache is None:
        meshes = [read_mesh(p) for p in mesh_paths]
        doc = detect_key_landmarks(meshes, [str(p) for p in mesh_paths], detection)
    else:
        from conformorph.pipelines.face_morph.key_cache import DirectoryArtifactStore
        from conformorph.pipelines.face_morph.landmark_cache import cached_detection_document

        doc = cached_detection_document(mesh_paths, DirectoryArtifactStore(cache), detection)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / LANDMARK_FILE
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(doc) + "\n", encoding="utf-8")
    tmp.replace(path)
    return path, landmark_report(doc, LANDMARK_FILE)


def fill_landmark_document(
    given: list[list[Any]], indices: Sequence[int], detected: dict[str, Any]
) -> dict[str, Any]:
    """Detected 68-point landmarks with the given points put at their ibug indices.

    Parameters
    ----------
    given : list of lists
        Every mesh's given landmarks (vertex ids or points), as parsed.
    indices : sequence of int
        The 0-based ibug index of each given position.
    detected : dict
        A document of :func:`write_detected_landmarks` (68 points and a confidence
        per point and mesh).

    Returns
    -------
    dict
        The detected document with ``landmarks[i][indices[j]] = given[i][j]`` and
        full confidence there, and ``filled``: which indices were given.
    """
    doc = json.loads(json.dumps(detected))  # a deep copy of plain JSON
    rows, conf = doc["landmarks"], doc.get("confidence")
    for i, points in enumerate(given):
        for j, k in enumerate(indices):
            rows[i][k] = points[j]
            if conf is not None:
                conf[i][k] = 1.0
    doc["filled"] = {
        "given_indices": list(indices),
        "detected_indices": sorted(set(range(len(rows[0]))) - set(indices)),
    }
    return doc


def _locate_given(
    doc: dict[str, Any],
    given: list[list[Any]],
    indices: Sequence[int],
    meshes: Sequence[tuple[Any, Any]],
) -> None:
    """Keep a filled document's per-point surface fields (``triangles``, ``barycentric``,
    ``vertex_ids``) true to the given points, which are written as surface points."""
    import numpy as np

    from conformorph.pipelines.landmarks_io import resolve_landmarks

    for i, (V, F) in enumerate(meshes):
        s = resolve_landmarks(given[i], V, F, mesh_index=i)
        for j, k in enumerate(indices):
            doc["landmarks"][i][k] = s.points[j].tolist()
            if "triangles" in doc:
                doc["triangles"][i][k] = int(s.triangle[j])
            if "barycentric" in doc:
                doc["barycentric"][i][k] = s.barycentric[j].tolist()
            if "vertex_ids" in doc:
                corner = int(F[s.triangle[j]][int(np.argmax(s.barycentric[j]))])
                doc["vertex_ids"][i][k] = int(s.vertex[j]) if s.vertex[j] >= 0 else corner


def given_subset(
    data: Any, n_meshes: int, where: str = "landmarks"
) -> tuple[list[list[Any]], list[int]]:
    """The given points and their ibug indices of a landmark document asking for a fill.

    Parameters
    ----------
    data : object
        Parsed JSON with ``"indices"`` (see :mod:`conformorph.pipelines.landmark_document`).
    n_meshes : int
    where : str
        How the error names the document.

    Returns
    -------
    given : list of n_meshes lists
        The checked entries (vertex ids or points) of every mesh.
    indices : list of int
        The 0-based ibug index of each position.

    Raises
    ------
    LandmarkError
        The document is not valid, or names no ``"indices"``.
    """
    from conformorph.pipelines.landmark_document import (
        LandmarkFormatError,
        landmark_indices,
        parse_landmark_json,
    )

    given = parse_landmark_json(data, n_meshes)
    indices = landmark_indices(data, len(given[0]))
    if indices is None:
        raise LandmarkFormatError(f'{where}: filling the missing landmarks needs "indices"')
    return given, indices


def fill_detected_landmarks(
    meshes: Sequence[tuple[Any, Any]],
    given: list[list[Any]],
    indices: Sequence[int],
    detected: dict[str, Any],
    file_name: str = LANDMARK_FILE,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The 68 landmarks of a subset filled by detection, and its ``metrics.json`` report.

    The one path of ``"fill": "auto"``: ``conformorph morph`` (:func:`run_face_morph_auto`)
    and the worker's morph job both call it.

    Parameters
    ----------
    meshes : sequence of (V, F)
        The key meshes as read, V (n_i, 3) float, F (m_i, 3) int: the given vertex ids
        and points refer to them.
    given : list of lists
        Every mesh's given landmarks, as parsed (:func:`given_subset`).
    indices : sequence of int
        The 0-based ibug index of each given position.
    detected : dict
        The detection's document (:func:`~conformorph.pipelines.landmark_detection.
        key_landmarks.detect_key_landmarks`) of the same meshes.
    file_name : str
        Where the filled document is written, beside the outputs.

    Returns
    -------
    document : dict
        :func:`fill_landmark_document` with the given points located on the surface
        (``landmarks``, ``triangles``, ``barycentric``, ``vertex_ids`` at their indices).
    report : dict
        The detection's :func:`~conformorph.pipelines.landmark_detection.key_landmarks.
        landmark_report` with ``given_indices`` and ``detected_indices`` (the filled ones).
    """
    from conformorph.pipelines.landmark_detection.key_landmarks import landmark_report

    report = landmark_report(detected, file_name)
    doc = fill_landmark_document(given, indices, detected)
    _locate_given(doc, given, indices, meshes)
    report["given_indices"] = list(indices)
    report["detected_indices"] = list(doc["filled"]["detected_indices"])
    return doc, report


def run_face_morph_auto(
    mesh_paths: Sequence[str | Path],
    outdir: str | Path,
    options: FaceMorphOptions | None = None,
    *,
    detection: Any = None,
    textures: Sequence[str | Path] | None = None,
    progress: ProgressFn | None = None,
    given: str | Path | None = None,
) -> dict[str, Any]:
    """:func:`~conformorph.pipelines.face_morph.run.run_face_morph` with detected landmarks.

    Parameters
    ----------
    mesh_paths, outdir, options, textures, progress
        As for ``run_face_morph``.
    detection : DetectionOptions, optional
    given : path, optional
        A landmark file with ``"indices"`` (and ``"fill": "auto"``): its points replace
        the detected ones at their ibug indices, with full confidence
        (:func:`fill_landmark_document`); the merged 68 are written to ``landmarks.json``.

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``), with ``landmarks``: the detection's report
        (and ``given_indices``, ``detected_indices`` when filled: :func:`fill_detected_landmarks`).
    """
    from conformorph.pipelines.face_morph.run import run_face_morph
    from conformorph.pipelines.mesh_io import read_mesh

    report = progress if progress is not None else (lambda f, stage: None)
    subset = None
    if given is not None:  # checked before the detection's seconds are spent
        subset = given_subset(json.loads(Path(given).read_text()), len(mesh_paths), str(given))
    cache = None if options is None else options.key_cache
    path, summary = write_detected_landmarks(mesh_paths, outdir, detection, cache=cache)
    if subset is not None:
        meshes = [read_mesh(p) for p in mesh_paths]
        doc, summary = fill_detected_landmarks(meshes, *subset, json.loads(path.read_text()))
        path.write_text(json.dumps(doc) + "\n", encoding="utf-8")
    report(0.1, "landmarks")

    def rest(f: float, stage: str) -> None:
        report(0.1 + 0.9 * f, stage)

    metrics = run_face_morph(mesh_paths, path, outdir, options, textures=textures, progress=rest)
    metrics["landmarks"] = summary
    (Path(outdir) / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics
