"""Interpolation of rigid motion and scale over key times, apart from the shape.

Section 4 of the face paper reconstructs every frame in a normalised, aligned
position; the similarity (rotation, translation, scale) that puts each key
surface back in place is interpolated separately: the rotation on SO(3) by a
C² cubic rotation spline (not by blending matrices, which leaves SO(3)), the
scale as a natural cubic spline of log s (so it stays positive), the
translation as a natural cubic spline.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, RotationSpline

from ._typing import FloatArray
from .rigid_alignment import SimilarityTransform


def _check_rotation(R: FloatArray) -> None:
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise ValueError(f"rotation must be a finite (3, 3) matrix, got {R.shape}")
    if np.abs(R @ R.T - np.eye(3)).max() > 1e-6 or np.linalg.det(R) <= 0:
        raise ValueError("rotation must be orthogonal with determinant +1")


def interpolate_rotations(
    times: FloatArray, rotations: FloatArray, t_eval: FloatArray
) -> FloatArray:
    """Cubic interpolation of rotations on SO(3) with extrapolation.

    Parameters
    ----------
    times : (N + 1,) float64
        Strictly increasing key times, N ≥ 1.
    rotations : (N + 1, 3, 3) float64
        Key rotation matrices.
    t_eval : (T,) float64
        Evaluation times.

    Returns
    -------
    (T, 3, 3) float64
        Rotation matrices. Inside [t0, tN]: scipy's ``RotationSpline`` (C²,
        the keys are reproduced, two keys give the geodesic, i.e. slerp);
        outside: the end rotation continued at the end angular velocity,
        ``R(t) = R_N exp((t - t_N) ω_N)`` (body frame).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> Rs = Rotation.from_rotvec([[0, 0, 0], [0, 0, np.pi / 2]]).as_matrix()
    >>> R = interpolate_rotations(np.array([0.0, 1.0]), Rs, np.array([0.5]))
    >>> round(float(Rotation.from_matrix(R[0]).magnitude()), 6) == round(np.pi / 4, 6)
    True
    """
    t = np.asarray(times, dtype=np.float64)
    Rm = np.asarray(rotations, dtype=np.float64)
    te = np.atleast_1d(np.asarray(t_eval, dtype=np.float64))
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("times must be at least 2 strictly increasing values")
    if Rm.shape != (t.size, 3, 3):
        raise ValueError(f"rotations must have shape ({t.size}, 3, 3), got {Rm.shape}")
    for R in Rm:
        _check_rotation(R)
    keys = Rotation.from_matrix(Rm)
    spline = RotationSpline(t, keys)
    out = np.zeros((te.size, 3, 3))
    inside = (te >= t[0]) & (te <= t[-1])
    if inside.any():
        out[inside] = spline(te[inside]).as_matrix()
    for end, mask in ((0, te < t[0]), (-1, te > t[-1])):
        if mask.any():
            w = spline(t[end], 1)  # body-frame angular rate at the end key
            dt = te[mask] - t[end]
            out[mask] = (keys[end] * Rotation.from_rotvec(dt[:, None] * w[None, :])).as_matrix()
    return out


def interpolate_similarity(
    times: FloatArray, transforms: Sequence[SimilarityTransform], t_eval: FloatArray
) -> list[SimilarityTransform]:
    """Interpolate similarity transforms: rotation on SO(3), log-scale and translation by splines.

    Parameters
    ----------
    times : (N + 1,) float64
        Strictly increasing key times.
    transforms : sequence of N + 1 SimilarityTransform
        Key similarities ``x ↦ s R x + t``.
    t_eval : (T,) float64
        Evaluation times (extrapolated outside the keys).

    Returns
    -------
    list of T SimilarityTransform

    Notes
    -----
    Translation and log-scale use natural cubic splines (the same end
    conditions as the shape homotopy); for two keys they are linear in t.
    """
    t = np.asarray(times, dtype=np.float64)
    if len(transforms) != t.size:
        raise ValueError(f"got {len(transforms)} transforms for {t.size} key times")
    te = np.atleast_1d(np.asarray(t_eval, dtype=np.float64))
    R = interpolate_rotations(t, np.stack([T.rotation for T in transforms]), te)
    scales = np.array([T.scale for T in transforms], dtype=np.float64)
    if np.any(scales <= 0) or not np.all(np.isfinite(scales)):
        raise ValueError("scales must be positive and finite")
    log_s = CubicSpline(t, np.log(scales), bc_type="natural", extrapolate=True)(te)
    trans = CubicSpline(
        t,
        np.stack([T.translation for T in transforms]),
        axis=0,
        bc_type="natural",
        extrapolate=True,
    )(te)
    return [
        SimilarityTransform(R[k], np.asarray(trans[k]), float(np.exp(log_s[k])))
        for k in range(te.size)
    ]


def rotation_to_quaternion_xyzw(R: FloatArray) -> FloatArray:
    """Unit quaternion (x, y, z, w) of a rotation matrix, w ≥ 0 (glTF's convention).

    Parameters
    ----------
    R : (3, 3) or (T, 3, 3) float64

    Returns
    -------
    (4,) or (T, 4) float64
    """
    R = np.asarray(R, dtype=np.float64)
    q = Rotation.from_matrix(R).as_quat()  # scalar-last (x, y, z, w)
    q = np.where((q[..., 3:4] < 0), -q, q)
    return np.asarray(q)
