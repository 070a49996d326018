"""Stage bodies: thin adapters between storage and one pipeline step each.

Each body loads its inputs by storage key (the uploaded mesh, or an artifact of
an earlier stage of the same job), calls one step of :mod:`pipelines`, writes
its outputs atomically through :class:`conformorph.worker.job_runner.StageContext` and
reports progress. Numerics are imported inside the bodies so that importing
this package (and the Celery task registry) stays cheap.

- :mod:`conformorph.worker.stages.validation`: the synchronous upload validations;
- :mod:`conformorph.worker.stages.surface`: conformal map, curvature, reconstruction;
- :mod:`conformorph.worker.stages.face_morph`: the face morph's five stages;
- :mod:`conformorph.worker.stages.morph2d`: the 2D morph;
- :mod:`conformorph.worker.stages.landmark_detection`: automatic face landmarks.
"""

from __future__ import annotations

from conformorph.worker.job_runner import StageBody
from conformorph.worker.stages import face_morph, landmark_detection, morph2d, surface
from conformorph.worker.stages.validation import validate_shape_upload, validate_upload

ALL_STAGE_BODIES: dict[str, StageBody] = {
    **surface.STAGE_BODIES,
    **face_morph.STAGE_BODIES,
    **morph2d.STAGE_BODIES,
    **landmark_detection.STAGE_BODIES,
}

__all__ = ["ALL_STAGE_BODIES", "validate_shape_upload", "validate_upload"]
