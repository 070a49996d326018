"""The landmark-detection stage (issue 16): ``POST /v1/landmark-detections`` runs it alone,
``POST /v1/morphs`` with ``"landmarks": "auto"`` runs it before ``prepare``.

It loads every mesh of the job, calls
:func:`conformorph.pipelines.landmark_detection.key_landmarks.detect_key_landmarks`, stores the
document as a landmark set of the job's owner (the id ``POST /v1/landmarks`` gives the
same document, so it can be passed as ``landmarks_id``) and writes it as the artifact
``landmarks.json`` with that id under ``landmarks_id``. A morph whose landmark set is a
subset asking for ``"fill": "auto"`` (parameters ``landmark_fill``, ``landmark_indices``)
gets the detected 68 with the given points at their ibug indices
(:func:`conformorph.pipelines.face_morph.auto_landmarks.fill_detected_landmarks`, as
``conformorph morph`` does), and its ``metrics.json`` report in the internal artifact
``landmark_report.json``. A named detection failure
ends the job with ``landmarks_not_detected`` (the reason's code and text in the
message, the mesh in ``field``); a worker without mediapipe or embreex with
``landmark_detection_unavailable``.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from conformorph.worker import names
from conformorph.worker.job_runner import StageBody, StageContext, input_field
from conformorph.worker.stages.validation import load_mesh_file

#: the artifact holding the detected landmarks (and ``landmarks_id``)
LANDMARKS_ARTIFACT = "landmarks.json"
#: the internal artifact holding the ``landmarks`` report of a filled subset
FILL_REPORT_ARTIFACT = "landmark_report.json"


class LandmarksNotDetectedError(ValueError):
    """Detection failed on a mesh; the message starts with the reason's code."""

    code = "landmarks_not_detected"


def landmark_set_id(owner: str, document: dict[str, Any]) -> str:
    """The id ``POST /v1/landmarks`` gives ``document`` for ``owner`` (the API's
    ``conformorph.service.api.uploads.content_id`` of the canonical JSON, kind ``landmarks``)."""
    blob = json.dumps(document, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(f"{owner}:landmarks:{blob}".encode()).hexdigest()[:32]


def detection_options_from_params(params: dict[str, Any]) -> Any:
    """The ``DetectionOptions`` of a job's parameters (the one place they map)."""
    from conformorph.pipelines.landmark_detection.detect import DetectionOptions

    return DetectionOptions(min_score=float(params.get("min_score", 0.5)))


def detect_landmarks_stage(ctx: StageContext) -> None:
    """Detect the 68 landmarks on every mesh of the job; store and publish the document."""
    from conformorph.pipelines.landmark_detection.detection_errors import LandmarkDetectionError
    from conformorph.pipelines.landmark_detection.key_landmarks import detect_key_landmarks

    p = ctx.params
    meshes = []
    for i, m in enumerate(p["meshes"]):
        with input_field(f"meshes[{i}]"):
            meshes.append(load_mesh_file(ctx.storage.local_path(m["storage_key"]), m["file_type"]))
    ctx.progress(0.1)
    ids = [str(m["id"]) for m in p["meshes"]]
    try:
        doc = detect_key_landmarks(meshes, ids, detection_options_from_params(p))
    except LandmarkDetectionError as exc:
        i = int(getattr(exc, "mesh_index", 0))
        err = LandmarksNotDetectedError(f"{exc.code}: mesh {exc}")
        err.conformorph_field = f"meshes[{i}]"  # type: ignore[attr-defined]
        raise err from exc
    if names.fills_landmarks(p):
        from conformorph.pipelines.face_morph.auto_landmarks import fill_detected_landmarks

        with input_field("landmarks_id"):  # a given point off its mesh, say
            doc, report = fill_detected_landmarks(
                meshes, p["landmarks"], p["landmark_indices"], doc, LANDMARKS_ARTIFACT
            )
        ctx.put_bytes(FILL_REPORT_ARTIFACT, json.dumps(report).encode(), internal=True)
    ctx.progress(0.9)
    set_id = landmark_set_id(ctx.job.owner, doc)
    ctx.store.add_landmarks(ctx.job.owner, set_id, doc)
    ctx.put_json(LANDMARKS_ARTIFACT, {**doc, "landmarks_id": set_id})


def detected_document(ctx: StageContext) -> dict[str, Any]:
    """The document the detection stage of this job wrote (``landmarks_id`` left out)."""
    doc: dict[str, Any] = json.loads(ctx.artifact_path(LANDMARKS_ARTIFACT).read_text())
    doc.pop("landmarks_id", None)
    return doc


def detected_report(ctx: StageContext) -> dict[str, Any]:
    """The ``landmarks`` entry of the morph's ``metrics.json`` for detected landmarks:
    :func:`~conformorph.pipelines.landmark_detection.key_landmarks.landmark_report`, or for
    a filled subset the report the detection stage kept."""
    if names.fills_landmarks(ctx.params):
        report: dict[str, Any] = json.loads(ctx.artifact_path(FILL_REPORT_ARTIFACT).read_text())
        return report
    from conformorph.pipelines.landmark_detection.key_landmarks import landmark_report

    return landmark_report(detected_document(ctx), LANDMARKS_ARTIFACT)


STAGE_BODIES: dict[str, StageBody] = {names.STAGE_DETECT_LANDMARKS: detect_landmarks_stage}
