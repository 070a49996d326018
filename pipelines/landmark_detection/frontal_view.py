"""Choosing the view: the mesh's principal axes give candidate cameras, the detector picks one,
and the eyes set its roll.

A face mesh is wider and taller than it is deep, so its axis of least variance
is close to the viewing direction of a frontal picture and the other two
principal axes are close to the image axes. Their signs are arbitrary: the
candidates are both directions along the depth axis, each at the four quarter
turns about it. Each candidate is scored by the face detector, and a candidate
seen from behind (the detector is as confident there, with left and right
swapped) is rejected by depth: the nose tip must be nearer the camera than the
eyes. The roll is then set from the eye line, so that the chosen view does not
depend on how the mesh was turned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.landmark_detection.mediapipe_detector import FaceDetection
from conformorph.pipelines.landmark_detection.render import OrthographicCamera, Render


@dataclass(frozen=True)
class ViewCandidate:
    """One scored candidate view.

    Attributes
    ----------
    render : Render
        The candidate's render (unrotated).
    quarter_turns : int
        How many counter-clockwise quarter turns of the image the detector saw.
    detection : FaceDetection or None
        The detection, its positions mapped back to the unrotated image.
    nose_in_front : bool
        The nose tip's depth exceeds both eyes' (a frontal, not a rear, view).
    """

    render: Render
    quarter_turns: int
    detection: FaceDetection | None
    nose_in_front: bool


def principal_axes(V: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The centroid and principal axes of the vertices.

    Parameters
    ----------
    V : (n, 3) float64

    Returns
    -------
    centroid : (3,) float64
    axes : (3, 3) float64
        Rows: unit axes by decreasing variance, completed to a right-handed frame.
    """
    c = V.mean(axis=0)
    X = V - c
    w, U = np.linalg.eigh(X.T @ X)
    axes = U[:, np.argsort(w)[::-1]].T.copy()
    axes[2] = np.cross(axes[0], axes[1])
    return c, axes


def candidate_cameras(V: NDArray[np.float64], size: int, margin: float = 0.05) -> list[
    OrthographicCamera
]:
    """Two cameras along the least-variance axis (both ways), image up along the largest axis.

    Parameters
    ----------
    V : (n, 3) float64
    size : int
        Image size in pixels.
    margin : float
        Blank border, a fraction of the image on each side.

    Returns
    -------
    list of 2 OrthographicCamera
        Each frames the whole mesh.
    """
    c, axes = principal_axes(V)
    out = []
    for sign in (1.0, -1.0):
        # right, up, backward: right x up = backward (right-handed, so the image is not mirrored)
        R = np.vstack([sign * axes[1], axes[0], -sign * axes[2]])
        ext = np.abs((V - c) @ R[:2].T).max()
        out.append(OrthographicCamera(R, c, 2.0 * ext / ((1.0 - 2.0 * margin) * size), size))
    return out


def unrotate_pixels(p: NDArray[np.float64], quarter_turns: int, size: int) -> NDArray[np.float64]:
    """Positions (n, 2) in ``np.rot90(image, k)`` mapped to the unrotated image."""
    q = np.asarray(p, dtype=np.float64).reshape(-1, 2).copy()
    for _ in range(quarter_turns % 4):
        q = np.column_stack([size - q[:, 1], q[:, 0]])
    return q


def depth_at(render: Render, pixels: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rendered depth at the nearest pixel of each position (n, 2); -inf off the mesh."""
    s = render.camera.size
    ij = np.clip(np.floor(np.asarray(pixels)).astype(np.int64), 0, s - 1)
    return render.depth[ij[:, 1], ij[:, 0]]


def nose_in_front(render: Render, nose: NDArray[np.float64], eyes: NDArray[np.float64]) -> bool:
    """True when the surface at ``nose`` (2,) is nearer the camera than at both ``eyes`` (2, 2)."""
    d = depth_at(render, np.vstack([nose, eyes]))
    return bool(np.isfinite(d[0]) and d[0] > d[1] and d[0] > d[2])


def roll_to_eyes(
    camera: OrthographicCamera, right_eye: NDArray[np.float64], left_eye: NDArray[np.float64]
) -> OrthographicCamera:
    """The camera rolled so that the eye line is horizontal, the subject's right eye on the left.

    Parameters
    ----------
    camera : OrthographicCamera
    right_eye, left_eye : (2,) float64
        Pixel positions in ``camera``'s image of the subject's right and left eye.
    """
    d = np.asarray(left_eye, dtype=np.float64) - np.asarray(right_eye, dtype=np.float64)
    return camera.rolled(float(np.arctan2(-d[1], d[0])))


def framed_on(
    camera: OrthographicCamera, center_px: NDArray[np.float64], width_px: float, fraction: float,
    size: int,
) -> OrthographicCamera:
    """A camera of the same orientation centred on ``center_px`` (2,), where ``width_px`` pixels of
    ``camera``'s image fill ``fraction`` of a ``size``-pixel image."""
    half = 0.5 * camera.size
    R = camera.rotation
    cx = (center_px[0] - half) * camera.pixel_size
    cy = (half - center_px[1]) * camera.pixel_size
    center = camera.center + cx * R[0] + cy * R[1]
    pixel_size = width_px * camera.pixel_size / (fraction * size)
    return OrthographicCamera(R, center, float(pixel_size), size)
