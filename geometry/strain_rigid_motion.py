"""Rigid motion of the strain morph: the paper's main steps (1) and (5).

Step (1) removes the rigid motion between source and target with two
reference points A (translation) and B (rotation) and fixes the solver's gauge;
step (5) puts the interpolated rotation and translation back on every frame.
The paper gives these steps no equation number (Section "Rigid body motion"
and the summary of main steps); K of eq. (11) is singular without them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .point_location import locate_points


def _rotation(theta: float) -> FloatArray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def wrap_angle(theta: float) -> float:
    """Angle in (−π, π].

    Parameters
    ----------
    theta : float

    Returns
    -------
    float

    Examples
    --------
    >>> wrap_angle(-3.5 * 3.141592653589793) == wrap_angle(0.5 * 3.141592653589793)
    True
    """
    w = float(np.mod(theta + np.pi, 2.0 * np.pi) - np.pi)
    return np.pi if w == -np.pi else w


@dataclass(frozen=True)
class RigidMotion:
    """Reference points A, B and the rigid motion between source and target (step 1).

    Attributes
    ----------
    F : (m, 3) int64
        Triangles of the meshes the points are followed on.
    ref_face : (2,) int64
        Triangle holding A⁰ and B⁰ in the source.
    ref_bary : (2, 3) float64
        Their barycentric coordinates.
    A0 : (2,) float64
        A in the source.
    theta0 : float
        Angle of A⁰B⁰.
    rotation : float
        R, the angle from A⁰B⁰ to AⁿBⁿ in (−π, π].
    translation : (2,) float64
        T, the vector from A⁰ to Aⁿ.
    """

    F: IntArray
    ref_face: IntArray
    ref_bary: FloatArray
    A0: FloatArray
    theta0: float
    rotation: float
    translation: FloatArray

    def follow(self, X: FloatArray) -> FloatArray:
        """A and B, (2, 2), carried by their barycentric coordinates to positions X (n, 2)."""
        return np.asarray(
            np.einsum("kj,kjd->kd", self.ref_bary, X[self.F[self.ref_face]]), dtype=np.float64
        )


def rigid_motion(
    source_V: FloatArray,
    target_V: FloatArray,
    F: IntArray,
    reference_points: FloatArray | None = None,
) -> RigidMotion:
    """The rotation R and translation T from source to target through A and B (step 1).

    Parameters
    ----------
    source_V, target_V : (n, 2) float64
        Compatible meshes.
    F : (m, 3) int64
    reference_points : (2, 2) float64, optional
        A⁰, B⁰ inside the source; default the vertex nearest the centroid and
        the vertex farthest from it. Aⁿ, Bⁿ are their images under the
        piecewise-linear map source → target.

    Returns
    -------
    RigidMotion

    Raises
    ------
    ValueError
        Reference points of the wrong shape, outside the source, or coincident.
    """
    centroid = source_V.mean(axis=0)
    if reference_points is None:
        ia = int(np.argmin(np.linalg.norm(source_V - centroid, axis=1)))
        ib = int(np.argmax(np.linalg.norm(source_V - source_V[ia], axis=1)))
        reference_points = source_V[[ia, ib]]
    ref = np.asarray(reference_points, dtype=np.float64)
    if ref.shape != (2, 2):
        raise ValueError(f"reference_points must have shape (2, 2), got {ref.shape}")
    ref_loc = locate_points(source_V, F, ref)
    if np.any(ref_loc.distance > 1e-9 * float(np.ptp(source_V, axis=0).max())):
        raise ValueError("reference points A, B must lie inside the source shape")
    if np.linalg.norm(ref[1] - ref[0]) <= 1e-12 * np.ptp(source_V, axis=0).max():
        raise ValueError("reference points A and B coincide")
    probe = RigidMotion(F, ref_loc.triangle, ref_loc.barycentric, ref[0], 0.0, 0.0, ref[0])
    A0, B0 = probe.follow(source_V)
    An, Bn = probe.follow(target_V)
    theta0 = float(np.arctan2(*(B0 - A0)[::-1]))
    R = wrap_angle(float(np.arctan2(*(Bn - An)[::-1])) - theta0)
    return RigidMotion(F, ref_loc.triangle, ref_loc.barycentric, A0, theta0, R, np.asarray(An - A0))


def gauge_vertices(source_V: FloatArray, A0: FloatArray) -> tuple[int, int]:
    """The gauge vertices: a nearest A⁰ (both coordinates fixed), b farthest from a (y fixed).

    Parameters
    ----------
    source_V : (n, 2) float64
    A0 : (2,) float64

    Returns
    -------
    a, b : int
    """
    a = int(np.argmin(np.linalg.norm(source_V - A0, axis=1)))
    b = int(np.argmax(np.linalg.norm(source_V - source_V[a], axis=1)))
    return a, b


def to_gauge(X: FloatArray, a: int, b: int) -> FloatArray:
    """X moved so that vertex a is at the origin and vertex b on the +x axis.

    Parameters
    ----------
    X : (n, 2) float64
    a, b : int

    Returns
    -------
    (n, 2) float64
    """
    d = X[b] - X[a]
    return (X - X[a]) @ _rotation(-float(np.arctan2(d[1], d[0]))).T


def restore_rigid_motion(X_all: FloatArray, times: FloatArray, motion: RigidMotion) -> FloatArray:
    """Frames with the interpolated rigid motion put back through A and B (step 5).

    A moves to ``A⁰ + t T`` and AB turns to the angle ``θ⁰ + t R``.

    Parameters
    ----------
    X_all : (T, n, 2) float64
        Frames in the gauge frame.
    times : (T,) float64
    motion : RigidMotion

    Returns
    -------
    (T, n, 2) float64
    """
    frames = np.zeros_like(X_all)
    for i, t in enumerate(times):
        X = X_all[i]
        At, Bt = motion.follow(X)
        d = Bt - At
        theta = motion.theta0 + float(t) * motion.rotation - float(np.arctan2(d[1], d[0]))
        frames[i] = (X - At) @ _rotation(theta).T + motion.A0 + float(t) * motion.translation
    return frames
