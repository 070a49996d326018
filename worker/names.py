"""Task and queue names shared by the API (which sends by name) and the workers.

The API never imports task bodies: it sends these names through a thin client
Celery app. Queue names contain no dot (kombu's filesystem transport parses
file names at the first dot).
"""

from __future__ import annotations

#: long-running job stages
QUEUE_JOBS = "conformorph-jobs"
#: short synchronous requests from the API (upload validation)
QUEUE_INTERACTIVE = "conformorph-interactive"
#: webhook deliveries: their own queue and workers, so a slow receiver (each attempt
#: bounded by ``callback_timeout`` in all) never holds an upload's validation
QUEUE_WEBHOOKS = "conformorph-webhooks"

VALIDATE_MESH = "conformorph.validate_mesh"
VALIDATE_SHAPE = "conformorph.validate_shape"
#: one webhook POST (webhooks queue); one retention pass (interactive queue, short)
DELIVER_CALLBACK = "conformorph.deliver_callback"
CLEANUP = "conformorph.cleanup"
#: an uploaded mesh's per-mesh work (key artifact), on the jobs queue after its upload
PRECOMPUTE_KEY = "conformorph.precompute_key"

#: job stages: stage name -> task name
STAGE_CONFORMAL_MAP = "conformal_map"
STAGE_CURVATURE = "curvature"
STAGE_RECONSTRUCT = "reconstruct"
STAGE_MORPH_PREPARE = "prepare"
STAGE_MORPH_REGISTER = "register"
STAGE_MORPH_FRAMES = "frames"
STAGE_MORPH_EXPORT = "export"
STAGE_MORPH_METRICS = "metrics"
STAGE_MORPH2D = "morph2d"
STAGE_DETECT_LANDMARKS = "detect_landmarks"

STAGE_TASKS: dict[str, str] = {
    STAGE_CONFORMAL_MAP: "conformorph.stage.conformal_map",
    STAGE_CURVATURE: "conformorph.stage.curvature",
    STAGE_RECONSTRUCT: "conformorph.stage.reconstruct",
    STAGE_MORPH_PREPARE: "conformorph.stage.prepare",
    STAGE_MORPH_REGISTER: "conformorph.stage.register",
    STAGE_MORPH_FRAMES: "conformorph.stage.frames",
    STAGE_MORPH_EXPORT: "conformorph.stage.export",
    STAGE_MORPH_METRICS: "conformorph.stage.metrics",
    STAGE_MORPH2D: "conformorph.stage.morph2d",
    STAGE_DETECT_LANDMARKS: "conformorph.stage.detect_landmarks",
}

#: job kinds -> their stages, in order
KIND_CONFORMAL_MAP = "conformal_map"
KIND_RECONSTRUCTION = "reconstruction"
KIND_MORPH = "morph"
KIND_MORPH2D = "morph2d"
KIND_LANDMARK_DETECTION = "landmark_detection"

KIND_STAGES: dict[str, list[str]] = {
    KIND_CONFORMAL_MAP: [STAGE_CONFORMAL_MAP],
    KIND_RECONSTRUCTION: [STAGE_CONFORMAL_MAP, STAGE_CURVATURE, STAGE_RECONSTRUCT],
    # animation.glb is published by "export", before the slower error metrics
    KIND_MORPH: [
        STAGE_MORPH_PREPARE,
        STAGE_MORPH_REGISTER,
        STAGE_MORPH_FRAMES,
        STAGE_MORPH_EXPORT,
        STAGE_MORPH_METRICS,
    ],
    KIND_MORPH2D: [STAGE_MORPH2D],
    KIND_LANDMARK_DETECTION: [STAGE_DETECT_LANDMARKS],
}

#: the value of a morph's ``landmarks`` that asks for detected ones
AUTO_LANDMARKS = "auto"


#: the morph parameter of a landmark set whose document asks for ``"fill": "auto"``: the
#: value of its ``"fill"``; the parameter ``landmark_indices`` holds its ``"indices"``
LANDMARK_FILL = "landmark_fill"


def fills_landmarks(params: dict[str, object]) -> bool:
    """Whether a morph's given landmarks are a subset whose missing points are detected."""
    return params.get(LANDMARK_FILL) == AUTO_LANDMARKS


def detects_landmarks(params: dict[str, object]) -> bool:
    """Whether a morph detects landmarks: ``"landmarks": "auto"``, or a subset to fill."""
    return params.get("landmarks") == AUTO_LANDMARKS or fills_landmarks(params)


def stages_for(kind: str, params: dict[str, object]) -> list[str]:
    """The stages of a new job: its kind's, with landmark detection first for a morph that
    detects landmarks (:func:`detects_landmarks`)."""
    stages = list(KIND_STAGES[kind])
    if kind == KIND_MORPH and detects_landmarks(params):
        stages.insert(0, STAGE_DETECT_LANDMARKS)
    return stages


#: job states
QUEUED = "queued"
RUNNING = "running"
SUCCEEDED = "succeeded"
FAILED = "failed"
CANCELLED = "cancelled"
ACTIVE_STATES = (QUEUED, RUNNING)
TERMINAL_STATES = (SUCCEEDED, FAILED, CANCELLED)
