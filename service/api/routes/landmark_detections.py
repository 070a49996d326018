"""``POST /v1/landmark-detections``: find the 68 Multi-PIE landmarks of face meshes (a job).

The job's one stage, ``detect_landmarks`` (:mod:`conformorph.worker.stages.landmark_detection`),
writes ``landmarks.json``: the landmark document (surface points, vertex ids,
confidences, warnings) and its ``landmarks_id``, a landmark set of the caller that
``POST /v1/morphs`` takes as it is, or that can be fetched
(``GET /v1/landmarks/{id}/document``), edited and uploaded again
(``POST /v1/landmarks``). A failure ends the job with ``landmarks_not_detected``
(the reason: no face, a view from behind, a low score, a face too small in the
render, rays lost) or ``landmark_detection_unavailable`` (no mediapipe on the worker).
"""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.concurrency import run_in_threadpool

from conformorph.service.api.submit import JOB_RESPONSES, SubmissionDep, mesh_param, require_mesh
from conformorph.service.errors import ApiError
from conformorph.service.schemas import JobPublic, LandmarkDetectionCreate
from conformorph.worker import names

router = APIRouter(tags=["landmarks"])


@router.post(
    "/v1/landmark-detections",
    operation_id="detect_landmarks",
    status_code=202,
    responses=JOB_RESPONSES,
)
async def create_landmark_detection(body: LandmarkDetectionCreate, job: SubmissionDep) -> JobPublic:
    """Detect the 68 Multi-PIE landmarks on every mesh: ``landmarks.json`` (the document, with
    confidences and warnings, and ``landmarks_id``, a landmark set for ``POST /v1/morphs``)."""
    store, owner = job.store, job.owner
    n = len(body.meshes)
    if n > job.settings.max_key_frames:
        raise ApiError(
            422, "too_many_meshes", f"{n} meshes; the limit is {job.settings.max_key_frames}",
            "meshes",
        )
    meshes = []
    for i, mid in enumerate(body.meshes):
        m = await run_in_threadpool(require_mesh, store, owner, mid, f"meshes[{i}]")
        meshes.append(mesh_param(m))
    params = {"meshes": meshes, "min_score": body.min_score}
    return await job.submit(names.KIND_LANDMARK_DETECTION, params, body)
