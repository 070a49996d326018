"""Named failures of automatic landmark detection (ValueErrors: the CLI exits 2 with one line).

Each has a ``code`` for machine-readable reports. An open mouth is not an
error: it lowers the inner-lip points' confidence and adds a warning.
"""

from __future__ import annotations


class LandmarkDetectionError(ValueError):
    """Base class: the detector could not place the 68 landmarks reliably."""

    code = "landmark_detection_failed"


class NoFaceFoundError(LandmarkDetectionError):
    """No candidate view showed a face to the detector."""

    code = "no_face_found"


class ViewFromBehindError(LandmarkDetectionError):
    """Faces were found only in views from behind (nose farther than the eyes): left and right
    would be swapped."""

    code = "view_from_behind"


class LowDetectorScoreError(LandmarkDetectionError):
    """The best frontal view's detector score is below the threshold."""

    code = "low_detector_score"


class MeshTooSmallError(LandmarkDetectionError):
    """The face covers too few pixels of the render (the mesh is mostly something else)."""

    code = "mesh_too_small_in_render"


class RaysLostError(LandmarkDetectionError):
    """Rays through landmarks missed the surface (holes or the background) with no hit nearby."""

    code = "rays_lost"
