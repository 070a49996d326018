"""``detect_landmarks``: the Multi-PIE 68 landmarks of a face mesh, with no clicks.

The steps, one function each:

1. :func:`choose_view` — candidate cameras from the mesh's principal axes, scored by the
   face detector, rear views rejected, roll set from the eyes, framed on the face
   (:mod:`.frontal_view`);
2. :func:`facemesh_in_view` — render by ray casting (:mod:`.render`) and run FaceMesh
   (:mod:`.mediapipe_detector`); the roll and framing are refined once from FaceMesh's eyes;
3. :func:`multipie68_from_facemesh` — the 478 → 68 table (:mod:`.multipie68`);
4. :func:`surface_landmarks_from_pixels` — one ray per landmark gives its triangle and
   barycentric coordinates exactly; confidence per point and warnings.

Numbering: warnings and error messages, which people read, number the landmarks from 1
(the Multi-PIE convention and the viewer's markers); JSON arrays (``confidence``,
``low_confidence`` in metrics) are indexed from 0 as every JSON array is.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.landmark_detection import mediapipe_detector as mpd
from conformorph.pipelines.landmark_detection.detection_errors import (
    LowDetectorScoreError,
    MeshTooSmallError,
    NoFaceFoundError,
    RaysLostError,
    ViewFromBehindError,
)
from conformorph.pipelines.landmark_detection.frontal_view import (
    candidate_cameras,
    framed_on,
    nose_in_front,
    roll_to_eyes,
    unrotate_pixels,
)
from conformorph.pipelines.landmark_detection.multipie68 import (
    INNER_LIPS,
    load_multipie68_table,
    multipie68_from_facemesh,
)
from conformorph.pipelines.landmark_detection.render import (
    MeshRayCaster,
    OrthographicCamera,
    Render,
    SurfaceHits,
)


@dataclass(frozen=True)
class DetectionOptions:
    """Options of :func:`detect_landmarks`.

    Attributes
    ----------
    image_size : int
        Pixels of the final renders FaceMesh sees (default 512).
    search_size : int
        Pixels of the candidate renders the face detector scores (default 256).
    min_score : float
        Best frontal detector score below which detection fails (default 0.5).
    min_face_pixels : float
        Detector box width in the candidate render below which the face is too small (default 20).
    face_fraction : float
        Outer-eye-corner distance as a fraction of the final image width (default 0.3).
    open_mouth_ratio : float
        Inner-lip gap over outer-eye-corner distance above which the mouth counts as open
        (default 0.05): the inner-lip points get low confidence and a warning.
    lost_ray_pixels : float
        A landmark whose ray misses (a hole, or beyond the mesh's edge) takes the nearest surface
        pixel, with a warning and its confidence × 0.5 within this distance (default 4 px),
        × 0.1 beyond.
    max_lost_rays : int
        More lost rays than this and detection fails (default 34, half of them; meshes with
        open eye and mouth holes lose about 20).
    table_path : str or None
        The 478 → 68 table (default: the committed ``multipie68_table.json``).
    """

    image_size: int = 512
    search_size: int = 256
    min_score: float = 0.5
    min_face_pixels: float = 20.0
    face_fraction: float = 0.3
    open_mouth_ratio: float = 0.05
    lost_ray_pixels: float = 4.0
    max_lost_rays: int = 34
    table_path: str | None = None


@dataclass(frozen=True)
class FaceMeshView:
    """FaceMesh's answer in one rendered view.

    Attributes
    ----------
    render : Render
    points : (478, 2) float64
        FaceMesh points in pixels.
    score : float
        Detector score of the chosen view.
    """

    render: Render
    points: NDArray[np.float64]
    score: float


@dataclass(frozen=True)
class DetectedLandmarks:
    """The 68 Multi-PIE landmarks found on a mesh.

    Attributes
    ----------
    points : (68, 3) float64
        Surface points.
    triangle : (68,) int64
    barycentric : (68, 3) float64
    vertex : (68,) int64
        Nearest corner of each landmark's triangle.
    confidence : (68,) float64
        In [0, 1]: the detector score × sqrt(|cos|) of the surface's angle to the view,
        lowered for recovered rays and for inner lips on an open mouth.
    warnings : tuple of str
    score : float
        Detector score of the chosen view.
    pixels : (68, 2) float64
        Positions in the final render.
    view : FaceMeshView
        The final render and FaceMesh points.
    seconds : float
        Wall time (model load excluded).
    """

    points: NDArray[np.float64]
    triangle: NDArray[np.int64]
    barycentric: NDArray[np.float64]
    vertex: NDArray[np.int64]
    confidence: NDArray[np.float64]
    warnings: tuple[str, ...]
    score: float
    pixels: NDArray[np.float64]
    view: FaceMeshView
    seconds: float = field(default=0.0)


_MODELS: list[mpd.MediaPipeFaceModels] = []


def _numbers(indices: NDArray[np.int64] | list[int]) -> str:
    """0-based landmark indices as the 1-based numbers people read, e.g. ``14, 15``."""
    return ", ".join(str(int(i) + 1) for i in indices)


def shared_models() -> mpd.MediaPipeFaceModels:
    """MediaPipe models loaded once per process."""
    if not _MODELS:
        _MODELS.append(mpd.MediaPipeFaceModels())
    return _MODELS[0]


def choose_view(
    caster: MeshRayCaster, models: mpd.MediaPipeFaceModels, options: DetectionOptions
) -> tuple[OrthographicCamera, float]:
    """The frontal camera: best-scoring front candidate, rolled to the eyes, framed on the face.

    Returns
    -------
    camera : OrthographicCamera
        ``options.image_size`` pixels.
    score : float

    Raises
    ------
    NoFaceFoundError, ViewFromBehindError, LowDetectorScoreError, MeshTooSmallError
    """
    best: tuple[float, Render, mpd.FaceDetection] | None = None
    rear = 0
    for cam in candidate_cameras(caster.V, options.search_size):
        render = caster.render(cam)
        rgb = render.rgb()
        for k in range(4):
            det = models.detect_face(np.ascontiguousarray(np.rot90(rgb, k)))
            if det is None:
                continue
            kp = unrotate_pixels(det.keypoints, k, cam.size)
            box = unrotate_pixels(det.box.reshape(2, 2), k, cam.size)
            det = mpd.FaceDetection(det.score, np.concatenate([box.min(0), box.max(0)]), kp)
            if not nose_in_front(render, kp[2], kp[:2]):
                rear += 1
                continue
            if best is None or det.score > best[0]:
                best = (det.score, render, det)
    if best is None:
        if rear:
            raise ViewFromBehindError(
                f"a face was found only in views from behind ({rear} candidates: the nose is "
                "farther from the camera than the eyes); is the mesh's face side missing?"
            )
        raise NoFaceFoundError("no face found in any of the 8 candidate views of the mesh")
    score, render, det = best
    if score < options.min_score:
        raise LowDetectorScoreError(
            f"best face-detector score {score:.2f} is below {options.min_score:.2f}"
        )
    width = float(det.box[2] - det.box[0])
    if width < options.min_face_pixels:
        raise MeshTooSmallError(
            f"the face is {width:.0f} px wide in a {options.search_size} px render of the whole "
            f"mesh (at least {options.min_face_pixels:.0f} needed); crop the mesh to the face"
        )
    rolled = roll_to_eyes(render.camera, det.keypoints[0], det.keypoints[1])
    eye_dist = float(np.linalg.norm(det.keypoints[1] - det.keypoints[0]))
    framed = framed_on(
        render.camera, 0.5 * (det.box[:2] + det.box[2:]), 1.3 * eye_dist, options.face_fraction,
        options.image_size,
    )
    return OrthographicCamera(rolled.rotation, framed.center, framed.pixel_size,
                              options.image_size), score


def _facemesh_once(
    caster: MeshRayCaster, models: mpd.MediaPipeFaceModels, camera: OrthographicCamera
) -> tuple[Render, NDArray[np.float64], NDArray[np.float64]]:
    """Render, FaceMesh, and the subject's right and left eye centres (2, 2) in pixels."""
    render = caster.render(camera)
    pts = models.face_mesh_points(render.rgb())
    if pts is None:
        raise NoFaceFoundError("the face detector found a face but FaceMesh did not")
    eyes = np.vstack([
        0.5 * (pts[mpd.RIGHT_EYE_OUTER] + pts[mpd.RIGHT_EYE_INNER]),
        0.5 * (pts[mpd.LEFT_EYE_OUTER] + pts[mpd.LEFT_EYE_INNER]),
    ])
    if not nose_in_front(render, pts[mpd.NOSE_TIP], eyes):
        raise ViewFromBehindError("FaceMesh's nose tip is farther from the camera than its eyes")
    return render, pts, eyes


def facemesh_in_view(
    caster: MeshRayCaster, models: mpd.MediaPipeFaceModels, camera: OrthographicCamera,
    score: float, options: DetectionOptions,
) -> FaceMeshView:
    """FaceMesh on the render of ``camera``, then again rolled and framed on FaceMesh's own eyes
    (so that the final view depends on the face, not on how the mesh was turned).

    Raises
    ------
    NoFaceFoundError, ViewFromBehindError
    """
    _, pts, eyes = _facemesh_once(caster, models, camera)
    rolled = roll_to_eyes(camera, eyes[0], eyes[1])
    eye_dist = float(np.linalg.norm(pts[mpd.LEFT_EYE_OUTER] - pts[mpd.RIGHT_EYE_OUTER]))
    center = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    framed = framed_on(camera, center, eye_dist, options.face_fraction, options.image_size)
    final = OrthographicCamera(rolled.rotation, framed.center, framed.pixel_size,
                               options.image_size)
    render, pts, _ = _facemesh_once(caster, models, final)
    return FaceMeshView(render, pts, score)


def surface_landmarks_from_pixels(
    caster: MeshRayCaster, view: FaceMeshView, pixels: NDArray[np.float64],
    options: DetectionOptions,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64], list[str]]:
    """One ray per landmark pixel; a ray that misses takes the nearest hit pixel nearby.

    Parameters
    ----------
    caster : MeshRayCaster
    view : FaceMeshView
    pixels : (m, 2) float64
    options : DetectionOptions

    Returns
    -------
    triangle : (m,) int64
    barycentric : (m, 3) float64
    confidence : (m,) float64
        The detector score × sqrt(facing), × 0.5 or 0.1 where a ray was recovered.
    warnings : list of str

    Raises
    ------
    RaysLostError
        More than ``options.max_lost_rays`` rays missed the surface.
    """
    cam = view.render.camera
    hits = caster.cast(cam, pixels)
    triangle, bary = hits.triangle.copy(), hits.barycentric.copy()
    factor = np.ones(pixels.shape[0])
    warnings = []
    lost = np.flatnonzero(~hits.hit)
    hit_px = np.argwhere(view.render.triangle >= 0)[:, ::-1] + 0.5  # (x, y) centres
    if lost.size > options.max_lost_rays or (lost.size and not hit_px.size):
        raise RaysLostError(
            f"the rays through {lost.size} of the landmarks missed the surface (holes or the edge "
            f"of the mesh; at most {options.max_lost_rays} may): landmarks {_numbers(lost)}"
        )
    far = []
    for i in lost.tolist():
        d = np.linalg.norm(hit_px - pixels[i], axis=1)
        j = int(np.argmin(d))
        x, y = (hit_px[j] - 0.5).astype(np.int64)
        triangle[i], bary[i] = view.render.triangle[y, x], view.render.barycentric[y, x]
        factor[i] = 0.5 if d[j] <= options.lost_ray_pixels else 0.1
        if d[j] > options.lost_ray_pixels:
            far.append(i)
    if lost.size:
        warnings.append(
            f"rays through landmarks {_numbers(lost)} missed the surface (holes or the mesh's "
            f"edge); the nearest surface pixel was used"
            + (f", more than {options.lost_ray_pixels:g} px away for {_numbers(far)}" if far else "")
        )
    fixed = SurfaceHits(triangle >= 0, triangle, bary, np.zeros((triangle.size, 3)))
    confidence = view.score * np.sqrt(caster.facing(cam, fixed)) * factor
    return triangle, bary, np.clip(confidence, 0.0, 1.0), warnings


def open_mouth_warning(
    facemesh: NDArray[np.float64], confidence: NDArray[np.float64], options: DetectionOptions
) -> str | None:
    """Lower the inner-lip confidences (in place) and say so when the mouth is open.

    Parameters
    ----------
    facemesh : (478, 2) float64
    confidence : (68,) float64
        Modified in place.
    options : DetectionOptions
    """
    gap = float(np.linalg.norm(facemesh[mpd.UPPER_LIP_INNER] - facemesh[mpd.LOWER_LIP_INNER]))
    eyes = float(np.linalg.norm(facemesh[mpd.LEFT_EYE_OUTER] - facemesh[mpd.RIGHT_EYE_OUTER]))
    ratio = gap / max(eyes, 1e-300)
    if ratio <= options.open_mouth_ratio:
        return None
    idx = np.asarray(INNER_LIPS)
    confidence[idx] *= 0.3
    return (
        f"open mouth (inner-lip gap {ratio:.2f} of the eye distance): inner-lip landmarks "
        f"{idx[0] + 1}-{idx[-1] + 1} have low confidence"
    )


def detect_landmarks(
    V: NDArray[np.float64], F: NDArray[np.int64], options: DetectionOptions | None = None,
    *, models: mpd.MediaPipeFaceModels | None = None,
) -> DetectedLandmarks:
    """The 68 Multi-PIE landmarks of a face mesh, as surface points with confidences.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    options : DetectionOptions, optional
    models : MediaPipeFaceModels, optional
        Loaded models to reuse (default: loaded once per process).

    Returns
    -------
    DetectedLandmarks

    Raises
    ------
    NoFaceFoundError, ViewFromBehindError, LowDetectorScoreError, MeshTooSmallError,
    RaysLostError
        Named failures (all :class:`LandmarkDetectionError`, a ValueError).
    MediaPipeUnavailableError, RayCastingUnavailableError
        mediapipe or embreex is not installed.
    """
    options = options or DetectionOptions()
    models = models or shared_models()
    table = load_multipie68_table(options.table_path)
    t0 = time.perf_counter()
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    caster = MeshRayCaster(V, F)
    camera, score = choose_view(caster, models, options)
    view = facemesh_in_view(caster, models, camera, score, options)
    pixels = multipie68_from_facemesh(view.points, table)
    triangle, bary, confidence, warnings = surface_landmarks_from_pixels(
        caster, view, pixels, options
    )
    mouth = open_mouth_warning(view.points, confidence, options)
    if mouth:
        warnings.append(mouth)
    points = np.einsum("mj,mjk->mk", bary, V[F[triangle]])
    vertex = F[triangle, np.argmax(bary, axis=1)]
    return DetectedLandmarks(
        points, triangle, bary, vertex, confidence, tuple(warnings), score, pixels, view,
        time.perf_counter() - t0,
    )
