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


def run_face_morph_auto(
    mesh_paths: Sequence[str | Path],
    outdir: str | Path,
    options: FaceMorphOptions | None = None,
    *,
    detection: Any = None,
    textures: Sequence[str | Path] | None = None,
    progress: ProgressFn | None = None,
) -> dict[str, Any]:
    """:func:`~conformorph.pipelines.face_morph.run.run_face_morph` with detected landmarks.

    Parameters
    ----------
    mesh_paths, outdir, options, textures, progress
        As for ``run_face_morph``.
    detection : DetectionOptions, optional

    Returns
    -------
    dict
        The metrics (also in ``metrics.json``), with ``landmarks``: the detection's report.
    """
    from conformorph.pipelines.face_morph.run import run_face_morph

    report = progress if progress is not None else (lambda f, stage: None)
    cache = None if options is None else options.key_cache
    path, summary = write_detected_landmarks(mesh_paths, outdir, detection, cache=cache)
    report(0.1, "landmarks")

    def rest(f: float, stage: str) -> None:
        report(0.1 + 0.9 * f, stage)

    metrics = run_face_morph(mesh_paths, path, outdir, options, textures=textures, progress=rest)
    metrics["landmarks"] = summary
    (Path(outdir) / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics
