"""The MediaPipe calls: BlazeFace detection (a score and six key points) and FaceMesh (478 points).

``mediapipe==0.10.14`` ships both models inside its wheel, so they run offline
(the 1.x releases need downloaded ``.task`` files). The models are loaded once
per :class:`MediaPipeFaceModels`; :attr:`MediaPipeFaceModels.load_seconds` says
how long that took. Their native log lines and protobuf's deprecation warning are kept
out of the user's terminal (:mod:`.native_log`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.landmark_detection.native_log import (
    filter_protobuf_deprecation,
    native_stderr_silenced,
    quiet_native_logging_env,
)


class MediaPipeUnavailableError(ImportError):
    """The ``mediapipe`` package (0.10.14) is not installed."""


#: FaceMesh indices used by the checks (the canonical face model's numbering)
NOSE_TIP = 1
RIGHT_EYE_OUTER, RIGHT_EYE_INNER = 33, 133  # the subject's right eye (image left)
LEFT_EYE_OUTER, LEFT_EYE_INNER = 263, 362
UPPER_LIP_INNER, LOWER_LIP_INNER = 13, 14


@dataclass(frozen=True)
class FaceDetection:
    """The best BlazeFace detection in an image.

    Attributes
    ----------
    score : float
        Detector confidence in [0, 1].
    box : (4,) float64
        ``x0, y0, x1, y1`` in pixels.
    keypoints : (6, 2) float64
        Pixel positions of the subject's right eye, left eye, nose tip, mouth,
        right ear tragion, left ear tragion.
    """

    score: float
    box: NDArray[np.float64]
    keypoints: NDArray[np.float64]


def mediapipe_available() -> bool:
    """True when ``mediapipe`` imports."""
    quiet_native_logging_env()
    try:
        import mediapipe  # noqa: F401
    except ImportError:
        return False
    return True


class MediaPipeFaceModels:
    """BlazeFace (short range) and FaceMesh with attention (refined eyes and lips), static images.

    Parameters
    ----------
    min_detection_confidence : float
        Detections below this score are dropped by MediaPipe itself.

    Raises
    ------
    MediaPipeUnavailableError
    """

    def __init__(self, min_detection_confidence: float = 0.1) -> None:
        t0 = time.perf_counter()
        quiet_native_logging_env()
        filter_protobuf_deprecation()
        with native_stderr_silenced():
            self._load(min_detection_confidence)
        self.load_seconds = time.perf_counter() - t0

    def _load(self, min_detection_confidence: float) -> None:
        try:
            import mediapipe as mp
        except ImportError as exc:
            raise MediaPipeUnavailableError(
                "landmark detection needs mediapipe==0.10.14: run scripts/install_landmarks.sh"
            ) from exc
        self._detector: Any = mp.solutions.face_detection.FaceDetection(
            model_selection=0, min_detection_confidence=min_detection_confidence
        )
        self._mesh: Any = mp.solutions.face_mesh.FaceMesh(
            static_image_mode=True,
            refine_landmarks=True,
            max_num_faces=1,
            min_detection_confidence=min_detection_confidence,
        )
        self.version = str(getattr(mp, "__version__", "unknown"))
        blank = np.zeros((64, 64, 3), dtype=np.uint8)  # the first call builds the graphs
        self._detector.process(blank)
        self._mesh.process(blank)

    def detect_face(self, rgb: NDArray[np.uint8]) -> FaceDetection | None:
        """The highest-scoring face in ``rgb`` (h, w, 3) uint8, or None."""
        h, w = rgb.shape[:2]
        with native_stderr_silenced():
            res = self._detector.process(rgb)
        if not res.detections:
            return None
        best = max(res.detections, key=lambda d: float(d.score[0]))
        bb = best.location_data.relative_bounding_box
        box = np.array([bb.xmin * w, bb.ymin * h, (bb.xmin + bb.width) * w, (bb.ymin + bb.height) * h])
        kp = np.array([[k.x * w, k.y * h] for k in best.location_data.relative_keypoints])
        return FaceDetection(float(best.score[0]), box, kp)

    def face_mesh_points(self, rgb: NDArray[np.uint8]) -> NDArray[np.float64] | None:
        """FaceMesh's 478 points in pixels, (478, 2) float64 ``(x, y)``, or None when no face."""
        h, w = rgb.shape[:2]
        with native_stderr_silenced():
            res = self._mesh.process(rgb)
        if not res.multi_face_landmarks:
            return None
        lm = res.multi_face_landmarks[0].landmark
        return np.array([[p.x * w, p.y * h] for p in lm], dtype=np.float64)

    def close(self) -> None:
        """Release the MediaPipe graphs."""
        self._detector.close()
        self._mesh.close()
