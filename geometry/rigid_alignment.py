"""Scale normalisation and rigid alignment of surfaces by landmarks (section 3 of the face paper).

"The scaling differences can be corrected by normalizing each surface using its
diameter. The positional difference can be corrected by applying a sequence of
rigid translations ... Algorithms, such as the iterative closest point (ICP)
can be applied." Here: each surface is centred and divided by its diameter;
the landmark sets are aligned by the least-squares similarity (Kabsch /
Umeyama); the landmarks that do not move rigidly (expressions move the mouth,
not the nose bridge) are then trimmed iteratively, and optionally the surface
around the rigid landmarks is matched by trimmed closest-point ICP.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, cKDTree
from scipy.spatial.distance import cdist

from ._typing import BoolArray, FloatArray
from .threads import available_threads


@dataclass(frozen=True)
class SimilarityTransform:
    """The map :math:`x \\mapsto s R x + t`.

    Attributes
    ----------
    rotation : (3, 3) float64
        Proper rotation (det = +1).
    translation : (3,) float64
    scale : float
        Positive.
    """

    rotation: FloatArray
    translation: FloatArray
    scale: float

    def apply(self, X: FloatArray) -> FloatArray:
        """Apply to points.

        Parameters
        ----------
        X : (p, 3) float64

        Returns
        -------
        (p, 3) float64
        """
        return np.asarray(self.scale * (np.asarray(X) @ self.rotation.T) + self.translation)

    def inverse(self) -> SimilarityTransform:
        """The inverse similarity."""
        Rt = self.rotation.T
        return SimilarityTransform(Rt, -(Rt @ self.translation) / self.scale, 1.0 / self.scale)

    def compose(self, first: SimilarityTransform) -> SimilarityTransform:
        """``self ∘ first`` (apply ``first``, then ``self``)."""
        return SimilarityTransform(
            self.rotation @ first.rotation,
            self.scale * (self.rotation @ first.translation) + self.translation,
            self.scale * first.scale,
        )

    @staticmethod
    def identity() -> SimilarityTransform:
        """The identity map."""
        return SimilarityTransform(np.eye(3), np.zeros(3), 1.0)


def surface_diameter(V: FloatArray) -> float:
    """Largest distance between two vertices (the surface's diameter).

    Parameters
    ----------
    V : (n, 3) float64

    Returns
    -------
    float

    Notes
    -----
    The farthest pair lies on the convex hull, so only hull vertices are
    compared (exact, and fast for scanned faces whose hulls have a few
    thousand vertices at most). Planar input falls back to all points.

    Examples
    --------
    >>> import numpy as np
    >>> surface_diameter(np.array([[0.0, 0, 0], [3, 0, 0], [0, 4, 0], [1, 1, 1]]))
    5.0
    """
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] < 2:
        raise ValueError(f"V must be (n, 3) with n ≥ 2, got {V.shape}")
    if not np.all(np.isfinite(V)):
        raise ValueError("V has non-finite coordinates")
    try:
        H = V[ConvexHull(V).vertices]
    except Exception:  # coplanar / degenerate input: QhullError
        H = V
    best = 0.0
    for s in range(0, H.shape[0], 2048):
        best = max(best, float(cdist(H[s : s + 2048], H).max()))
    return best


def normalize_by_diameter(V: FloatArray) -> tuple[FloatArray, SimilarityTransform]:
    """Centre a surface at its vertex centroid and scale it to unit diameter.

    Parameters
    ----------
    V : (n, 3) float64

    Returns
    -------
    V_normalized : (n, 3) float64
        ``(V - centroid) / diameter``.
    transform : SimilarityTransform
        The map back: ``transform.apply(V_normalized) == V``.
    """
    V = np.asarray(V, dtype=np.float64)
    diam = surface_diameter(V)
    if diam <= 0:
        raise ValueError("all vertices coincide; the surface has zero diameter")
    c = V.mean(axis=0)
    return (V - c) / diam, SimilarityTransform(np.eye(3), c, diam)


def umeyama_alignment(
    source_points: FloatArray,
    target_points: FloatArray,
    *,
    with_scale: bool = True,
    weights: FloatArray | None = None,
) -> SimilarityTransform:
    """Least-squares similarity (or rigid) transform taking source points onto target points.

    Minimises :math:`\\sum_i w_i |s R x_i + t - y_i|^2` over rotations R
    (det +1), translations t and, when ``with_scale``, scales s > 0 (Umeyama
    1991; Kabsch when ``with_scale`` is False).

    Parameters
    ----------
    source_points : (p, 3) float64
    target_points : (p, 3) float64
    with_scale : bool, default True
    weights : (p,) float64, optional
        Non-negative, not all zero.

    Returns
    -------
    SimilarityTransform

    References
    ----------
    S. Umeyama, "Least-squares estimation of transformation parameters between
    two point patterns", IEEE TPAMI 13(4), 1991. doi:10.1109/34.88573
    """
    X = np.asarray(source_points, dtype=np.float64)
    Y = np.asarray(target_points, dtype=np.float64)
    if X.ndim != 2 or X.shape[1] != 3 or X.shape != Y.shape:
        raise ValueError(f"point sets must both be (p, 3), got {X.shape} and {Y.shape}")
    if X.shape[0] < 3:
        raise ValueError(f"need at least 3 point pairs, got {X.shape[0]}")
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
        raise ValueError("point sets have non-finite coordinates")
    w = np.ones(X.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (X.shape[0],) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError("weights must be non-negative, not all zero, one per point")
    w = w / w.sum()
    mx = w @ X
    my = w @ Y
    Xc = X - mx
    Yc = Y - my
    Sigma = (Yc * w[:, None]).T @ Xc
    U, D, Vt = np.linalg.svd(Sigma)
    E = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        E[2, 2] = -1.0
    R = U @ E @ Vt
    var_x = float(w @ np.sum(Xc**2, axis=1))
    s = float(np.trace(np.diag(D) @ E) / var_x) if with_scale and var_x > 0 else 1.0
    if with_scale and s <= 0:
        raise ValueError("degenerate point configuration: the fitted scale is not positive")
    return SimilarityTransform(R, my - s * (R @ mx), s)


@dataclass(frozen=True)
class LandmarkAlignmentInfo:
    """Diagnostics of :func:`rigid_landmark_alignment`.

    Attributes
    ----------
    residuals : (m,) float64
        Distance of every aligned source landmark to its target.
    rigid : (m,) bool
        Landmarks kept as moving rigidly (used in the final fit).
    rms_all : float
        RMS residual over all landmarks.
    rms_rigid : float
        RMS residual over the rigid landmarks.
    iterations : int
        Trimming iterations until the rigid set stopped changing.
    icp_iterations : int
        Closest-point ICP iterations (0 when not run).
    icp_rms : float
        RMS closest-point distance of the ICP pairs kept at the end (NaN if
        not run).
    """

    residuals: FloatArray
    rigid: BoolArray
    rms_all: float
    rms_rigid: float
    iterations: int
    icp_iterations: int
    icp_rms: float


@dataclass(frozen=True)
class RigidAlignmentOptions:
    """Options of :func:`rigid_landmark_alignment`.

    Attributes
    ----------
    with_scale : bool
        Also fit a scale (surfaces are normally normalised by diameter first).
        Default False.
    trim_factor : float
        A landmark is non-rigid when its residual exceeds ``trim_factor`` times
        the median residual. Default 2.0.
    min_rigid_fraction : float
        Never keep fewer than this fraction of the landmarks (nor fewer than 3).
        Default 0.3.
    max_iterations : int
        Cap on the trimming iterations. Default 20.
    icp_iterations : int
        Closest-point ICP iterations after the landmark fit; run on the source
        vertices within ``icp_radius`` of a rigid landmark (the rigid part of
        the face), matched to their nearest target vertices, the worst
        ``1 - icp_trim`` of the pairs discarded at each iteration. Default 0.
    icp_radius : float
        In the units of the surfaces (relative when they are normalised). Default 0.1.
    icp_trim : float
        Fraction of closest-point pairs kept. Default 0.8.
    """

    with_scale: bool = False
    trim_factor: float = 2.0
    min_rigid_fraction: float = 0.3
    max_iterations: int = 20
    icp_iterations: int = 0
    icp_radius: float = 0.1
    icp_trim: float = 0.8


def rigid_landmark_alignment(
    source_landmarks: FloatArray,
    target_landmarks: FloatArray,
    *,
    source_surface: FloatArray | None = None,
    target_surface: FloatArray | None = None,
    options: RigidAlignmentOptions | None = None,
) -> tuple[SimilarityTransform, LandmarkAlignmentInfo]:
    """Align landmark sets rigidly, keeping only the landmarks that move rigidly.

    Parameters
    ----------
    source_landmarks : (m, 3) float64
        Landmarks on the (diameter-normalised) source surface.
    target_landmarks : (m, 3) float64
        Corresponding landmarks on the target surface.
    source_surface, target_surface : (n0, 3), (n1, 3) float64, optional
        Vertices of the two surfaces, for the ICP refinement.
    options : RigidAlignmentOptions, optional
        Scale, trimming and ICP (default ``RigidAlignmentOptions()``: no scale, no ICP).

    Returns
    -------
    transform : SimilarityTransform
        Maps source coordinates onto target coordinates.
    info : LandmarkAlignmentInfo
    """
    o = RigidAlignmentOptions() if options is None else options
    with_scale, trim_factor, icp_trim = o.with_scale, o.trim_factor, o.icp_trim
    min_rigid_fraction, max_iterations = o.min_rigid_fraction, o.max_iterations
    icp_iterations, icp_radius = o.icp_iterations, o.icp_radius
    X = np.asarray(source_landmarks, dtype=np.float64)
    Y = np.asarray(target_landmarks, dtype=np.float64)
    if X.shape != Y.shape or X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"landmark sets must both be (m, 3), got {X.shape} and {Y.shape}")
    m = X.shape[0]
    if m < 3:
        raise ValueError(f"need at least 3 landmarks, got {m}")
    if trim_factor <= 1.0:
        raise ValueError(f"trim_factor must be > 1, got {trim_factor}")
    if not 0 < icp_trim <= 1:
        raise ValueError(f"icp_trim must be in (0, 1], got {icp_trim}")
    keep_min = max(3, int(np.ceil(min_rigid_fraction * m)))
    rigid = np.ones(m, dtype=bool)
    T = umeyama_alignment(X, Y, with_scale=with_scale)
    it = 0
    for it in range(1, max_iterations + 1):  # noqa: B007 - the count is reported
        r = np.linalg.norm(T.apply(X) - Y, axis=1)
        med = float(np.median(r[rigid]))
        new = r <= trim_factor * max(med, 1e-300)
        if new.sum() < keep_min:
            new = np.zeros(m, dtype=bool)
            new[np.argsort(r)[:keep_min]] = True
        if np.array_equal(new, rigid):
            break
        rigid = new
        T = umeyama_alignment(X[rigid], Y[rigid], with_scale=with_scale)
    n_icp = 0
    icp_rms = float("nan")
    if icp_iterations > 0:
        if source_surface is None or target_surface is None:
            raise ValueError("ICP refinement needs source_surface and target_surface")
        S = np.asarray(source_surface, dtype=np.float64)
        tree_src = cKDTree(S)
        near = tree_src.query_ball_point(X[rigid], icp_radius)
        idx = np.unique(
            np.concatenate(
                [np.asarray(a, dtype=np.int64) for a in near] + [np.zeros(0, dtype=np.int64)]
            )
        )
        if idx.size >= 3:
            Sx = S[idx]
            tree = cKDTree(np.asarray(target_surface, dtype=np.float64))
            Tgt = np.asarray(target_surface, dtype=np.float64)
            for n_icp in range(1, icp_iterations + 1):  # noqa: B007
                Z = T.apply(Sx)
                d, j = tree.query(Z, workers=available_threads())  # same answer, any workers
                keep = d <= np.quantile(d, icp_trim)
                # landmarks stay in the fit with the weight of the surface pairs
                A = np.vstack([Sx[keep], X[rigid]])
                B = np.vstack([Tgt[j[keep]], Y[rigid]])
                wts = np.r_[
                    np.ones(int(keep.sum())), np.full(int(rigid.sum()), keep.sum() / rigid.sum())
                ]
                T_new = umeyama_alignment(A, B, with_scale=with_scale, weights=wts)
                step = np.abs(T_new.apply(Sx) - Z).max()
                T = T_new
                icp_rms = float(np.sqrt(np.mean(d[keep] ** 2)))
                if step < 1e-10:
                    break
    r = np.linalg.norm(T.apply(X) - Y, axis=1)
    info = LandmarkAlignmentInfo(
        residuals=r,
        rigid=rigid,
        rms_all=float(np.sqrt(np.mean(r**2))),
        rms_rigid=float(np.sqrt(np.mean(r[rigid] ** 2))),
        iterations=it,
        icp_iterations=n_icp,
        icp_rms=icp_rms,
    )
    return T, info
