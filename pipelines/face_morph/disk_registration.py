"""Stage 2b (section 4 of the face paper): the registration of each consecutive pair of key
disks, MT (the optimal Möbius transformation) and DMT (MT plus the thin-plate correction
that meets the landmarks), the DMT kept bijective on the consistent nodes it moves (the
fold guard of :func:`conformorph.geometry.disk_registration.register_disk_landmarks`); and the DMT fit
through extra correspondences given by the caller."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import LANDMARK_NOISE, Arrays

#: Smallest landmark confidence the ``tolerant`` fit uses (a weight of 0 would drop the
#: landmark from the Möbius fit and the ICP, and give it an infinite noise).
MIN_CONFIDENCE = 0.05


@dataclass(frozen=True)
class KeyPair:
    """Keys i − 1 (source) and i (target) of one registration, in the aligned frame.

    Attributes
    ----------
    index : int
        i, the target key.
    source, target : dict
        Their stage-1 dicts.
    source_X, target_X : (n_a, 3), (n_b, 3) float64
        Their aligned, normalised vertices.
    source_locator, target_locator : PointLocator
        Point location on their disks.
    source_lm, target_lm : (m, 3) float64
        Their landmarks in the aligned frame.
    landmark_fit : {"exact", "tolerant"}
        How the pair's DMT treats the landmarks (``RegistrationOptions.landmark_fit``).
    landmark_noise : float
        Landmark error (diameters, rms per axis) assumed at confidence 1.
    """

    index: int
    source: Arrays
    target: Arrays
    source_X: NDArray[np.float64]
    target_X: NDArray[np.float64]
    source_locator: Any
    target_locator: Any
    source_lm: NDArray[np.float64]
    target_lm: NDArray[np.float64]
    landmark_fit: str = "exact"
    landmark_noise: float = LANDMARK_NOISE

    @property
    def tolerant(self) -> bool:
        """Whether the landmarks are weighted and corrected rather than interpolated."""
        return self.landmark_fit == "tolerant"

    def landmark_weights(self) -> NDArray[np.float64]:
        """(m,) weight of every landmark pair: the lower of its two confidences
        (at least :data:`MIN_CONFIDENCE`)."""
        c = np.minimum(self.source["lm_confidence"], self.target["lm_confidence"])
        return np.asarray(np.maximum(c, MIN_CONFIDENCE), dtype=np.float64)

    def landmark_noise_disk(self) -> NDArray[np.float64]:
        """(m,) assumed error of every landmark pair on the target disk, per coordinate.

        Each landmark's 3D error is ``landmark_noise`` / its confidence (diameters,
        rms per axis); the pair's is the root sum of squares of the two, measured on
        the target disk through the target's length factor √λ at the landmark.
        """
        ca = np.maximum(self.source["lm_confidence"], MIN_CONFIDENCE)
        cb = np.maximum(self.target["lm_confidence"], MIN_CONFIDENCE)
        sigma = self.landmark_noise * np.sqrt(1.0 / ca**2 + 1.0 / cb**2)
        Q = self.target["lm_uv"]
        lam_b = self.target_locator.locate(Q).interpolate(self.target["F"], self.target["lam"])
        return np.asarray(sigma / np.sqrt(np.asarray(lam_b)), dtype=np.float64)

    def kernel_scale(self, P: NDArray[np.float64], Q: NDArray[np.float64]) -> NDArray[np.float64]:
        """λ1²/λ0² of the paper at corresponding disk points: the ratio of area factors.

        Parameters
        ----------
        P : (k, 2) float64
            Points on the source disk.
        Q : (k, 2) float64
            The corresponding points on the target disk.

        Returns
        -------
        (k,) float64
        """
        lam_b = self.target_locator.locate(Q).interpolate(self.target["F"], self.target["lam"])
        lam_a = self.source_locator.locate(P).interpolate(self.source["F"], self.source["lam"])
        return np.asarray(lam_b) / np.asarray(lam_a)


#: DMT fallbacks after which the map still interpolates its points exactly
EXACT_FALLBACKS = (None, "stepwise")


def boundary_polygon_radius(uv: NDArray[np.float64], F: NDArray[np.int64]) -> float:
    """The smallest radius of a point on a disk map's boundary polygon.

    The boundary vertices lie on the unit circle, its edges are chords; a point on the
    mesh's boundary (a vertex or on a boundary edge) therefore has a radius of at least
    the smallest chord midpoint's, cos(θ_max / 2) for the widest chord angle θ_max.

    Parameters
    ----------
    uv : (n, 2) float64
        A disk map (boundary on the unit circle).
    F : (m, 3) int64

    Returns
    -------
    float
        In (0, 1]; 1 for a boundary without chords (never: at least 3 vertices).
    """
    from conformorph.geometry.boundary_loop import boundary_loop

    b = boundary_loop(F)
    mid = 0.5 * (uv[b] + uv[np.roll(b, -1)])
    return float(np.sqrt((mid**2).sum(axis=1)).min())


def off_boundary(
    pair: KeyPair, P: NDArray[np.float64], Q: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """(k,) whether each correspondence P → Q lies off both disks' boundaries.

    The DMT's thin-plate part vanishes on the unit circle (its boundary taper
    1 − |z|², eq. 4 of the face paper keeps the boundary on the circle), so it cannot
    move a point of the boundary, and fitting one raises (|z| = 1) or, just inside,
    asks for an unbounded displacement that folds at every strength. A point counts
    as on the boundary when its radius reaches its disk's
    :func:`boundary_polygon_radius` (a landmark on a boundary vertex or edge of its
    mesh; nothing interior is that close to the circle unless it sits within a
    chord's sagitta of it). :func:`dmt_through` leaves such correspondences out of the
    DMT's fit (its Möbius and thin-plate parts; the MT baseline still fits them), so
    that the DMT meets the others instead of falling back to MT for all of them.
    """
    r_a = boundary_polygon_radius(pair.source["uv"], pair.source["F"])
    r_b = boundary_polygon_radius(pair.target["uv"], pair.target["F"])
    rP = np.sqrt((np.asarray(P) ** 2).sum(axis=1))
    rQ = np.sqrt((np.asarray(Q) ** 2).sum(axis=1))
    return np.asarray((rP < r_a - 1e-12) & (rQ < r_b - 1e-12))


def _off_boundary_landmarks(
    pair: KeyPair, P: NDArray[np.float64], Q: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """(k,) False for the rows of ``P → Q`` that are landmarks on a boundary: when ``P``
    starts with the pair's source landmarks (the landmark DMT and the fits through
    extra correspondences; their targets may be the landmarks' or where a tolerant fit
    put them), :func:`off_boundary` of those rows; every other row (the extra
    correspondences, whose own choice keeps them off the rim) is kept as given."""
    keep = np.ones(P.shape[0], dtype=bool)
    A = pair.source["lm_uv"]
    m = A.shape[0]
    if P.shape[0] >= m and np.array_equal(P[:m], A):
        keep[:m] = off_boundary(pair, A, Q[:m])
    return keep


def boundary_landmarks(pair: KeyPair) -> list[int]:
    """Indices of the landmarks on either key's boundary (see :func:`off_boundary`): the
    DMT's fit leaves them out, and ``metrics.json`` names them."""
    keep = off_boundary(pair, pair.source["lm_uv"], pair.target["lm_uv"])
    return [int(i) for i in np.flatnonzero(~keep)]


def dmt_through(
    pair: KeyPair,
    P: NDArray[np.float64],
    Q: NDArray[np.float64],
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    **fit: Any,
) -> Any:
    """The DMT of one pair through the disk points ``P`` → ``Q``, kept bijective on ``z_prev``.

    The one call behind every DMT of the face morph (landmarks alone, or with extra
    correspondences): landmarks on a disk's boundary are left out of the fit
    (:func:`off_boundary`; when at least 3 points remain), the thin-plate kernel is scaled by the pair's λ ratio
    (:meth:`KeyPair.kernel_scale`), and a fit that would fold falls back rather than
    folds (:func:`conformorph.geometry.disk_registration.register_disk_landmarks`, ``on_fold=
    "fallback"``).

    Parameters
    ----------
    pair : KeyPair
    P, Q : (k, 2) float64
        Corresponding points on the source and target disks (the landmarks first).
    z_prev : (p, 2) float64
        The consistent nodes carried to the source disk (where the map is used,
        hence checked for folds).
    cm_F : (f, 3) int64
        The consistent triangles.
    **fit
        Further keywords of ``register_disk_landmarks`` (``regularization``,
        ``max_steps``, ``fold_regularizations``), or ``tolerance``
        (:class:`conformorph.geometry.disk_registration.LandmarkTolerance`: then
        ``register_disk_landmarks_tolerant``).

    Returns
    -------
    DiskRegistration
        Its ``fallback`` says how a fold was avoided; see :func:`meets_its_points`.
    """
    from conformorph.geometry.disk_registration import (
        register_disk_landmarks,
        register_disk_landmarks_tolerant,
    )

    tolerance = fit.pop("tolerance", None)
    keep = _off_boundary_landmarks(pair, P, Q)
    if not keep.all() and int(keep.sum()) >= 3:  # boundary landmarks: out of the fit
        P, Q = P[keep], Q[keep]
        if tolerance is not None:
            m = pair.source["lm_uv"].shape[0]  # the tolerance's arrays: one per landmark
            k = keep[:m]
            tolerance = type(tolerance)(
                None if tolerance.weights is None else tolerance.weights[k],
                None if tolerance.smoothing is None else tolerance.smoothing[k],
            )
    if tolerance is not None:
        return register_disk_landmarks_tolerant(
            P, Q, z_prev, cm_F, tolerance, kernel_scale=pair.kernel_scale(P, Q), **fit
        )
    return register_disk_landmarks(
        P,
        Q,
        z_prev,
        cm_F,
        method="dmt",
        kernel_scale=pair.kernel_scale(P, Q),
        on_fold="fallback",
        **fit,
    )


def meets_its_points(registration: Any) -> bool:
    """Whether a DMT avoided folding without giving up its points (no fallback, or
    composed steps), i.e. it still interpolates them (up to its Tikhonov ε)."""
    return registration.fallback in EXACT_FALLBACKS


def tolerant_landmark_terms(pair: KeyPair) -> dict[str, Any]:
    """Keywords of the ``tolerant`` landmark DMT of one pair: Möbius weights and thin-plate
    smoothing (:func:`conformorph.geometry.landmark_smoothing.discrepancy_smoothing` on the landmarks
    after the weighted Möbius fit, with :meth:`KeyPair.landmark_noise_disk`)."""
    from conformorph.geometry.landmark_smoothing import discrepancy_smoothing
    from conformorph.geometry.mobius_registration import mobius_registration as fit_mobius

    P, Q = pair.source["lm_uv"], pair.target["lm_uv"]
    w = pair.landmark_weights()
    keep = off_boundary(pair, P, Q)  # the fit leaves boundary landmarks out (dmt_through)
    if int(keep.sum()) < 3:
        keep[:] = True
    T, _ = fit_mobius(P[keep], Q[keep], weights=w[keep])
    sm = discrepancy_smoothing(
        T.apply(P[keep]),
        Q[keep],
        pair.landmark_noise_disk()[keep],
        kernel_scale=pair.kernel_scale(P[keep], Q[keep]),
    )
    smoothing = np.zeros(P.shape[0])  # a boundary landmark's: unused
    smoothing[keep] = sm.smoothing
    return {"weights": w, "smoothing": smoothing, "kappa": sm.kappa, "chi": sm.chi}


def landmark_dmt(pair: KeyPair, z_prev: NDArray[np.float64], cm_F: NDArray[np.int64]) -> Any:
    """The DMT of one pair through its landmarks, kept bijective on ``z_prev``
    (:func:`dmt_through` with the landmarks only): the paper's, which interpolates
    them, or with ``pair.tolerant`` one that approximates them
    (:func:`tolerant_landmark_terms`).

    Parameters
    ----------
    pair : KeyPair
    z_prev : (p, 2) float64
        The consistent nodes carried to the source disk.
    cm_F : (f, 3) int64
        The consistent triangles.

    Returns
    -------
    DiskRegistration
        Its ``fallback`` says how a fold was avoided (stepwise, regularised, MT).
    """
    from conformorph.geometry.disk_registration import LandmarkTolerance

    fit: dict[str, Any] = {}
    if pair.tolerant:
        terms = tolerant_landmark_terms(pair)
        fit = {"tolerance": LandmarkTolerance(terms["weights"], terms["smoothing"])}
    return dmt_through(pair, pair.source["lm_uv"], pair.target["lm_uv"], z_prev, cm_F, **fit)


def mobius_registration(pair: KeyPair, z_prev: NDArray[np.float64], cm_F: NDArray[np.int64]) -> Any:
    """The MT of one pair (the optimal Möbius transformation of its landmarks, eq. 2)."""
    from conformorph.geometry.disk_registration import register_disk_landmarks

    return register_disk_landmarks(
        pair.source["lm_uv"], pair.target["lm_uv"], z_prev, cm_F, method="mt"
    )


def extra_correspondence_fit(
    pair: KeyPair,
    z_prev: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    extra: tuple[NDArray[np.float64], NDArray[np.float64]],
    *,
    regularization: float,
) -> tuple[Any | None, int, bool]:
    """The DMT through the landmarks and the caller's extra correspondences of one pair.

    Parameters
    ----------
    pair : KeyPair
    z_prev : (p, 2) float64
        The consistent nodes on the source disk.
    cm_F : (f, 3) int64
    extra : ((k, 2), (k, 2)) float64
        Further corresponding points on the two disks (e.g. semi-landmarks).
    regularization : float
        Tikhonov ε of the fit.

    Returns
    -------
    registration : DiskRegistration or None
        The fit, or None when there are no extra points or when it can only avoid
        folding by smoothing (then the landmark DMT is kept).
    n_extra : int
        Correspondences used (0 when none or rejected).
    rejected : bool
        The fit was rejected (reported as ``extra_rejected``).
    """

    pe = np.asarray(extra[0], dtype=np.float64).reshape(-1, 2)
    qe = np.asarray(extra[1], dtype=np.float64).reshape(-1, 2)
    if pe.shape != qe.shape:
        raise ValueError(f"extra correspondences of pair {pair.index}: {pe.shape} vs {qe.shape}")
    if not pe.shape[0]:
        return None, 0, False
    Pe = np.vstack([pair.source["lm_uv"], pe])
    Qe = np.vstack([pair.target["lm_uv"], qe])
    reg_e = dmt_through(pair, Pe, Qe, z_prev, cm_F, regularization=regularization)
    if meets_its_points(reg_e):
        return reg_e, int(pe.shape[0]), False
    return None, 0, True


def surface_error(p: Arrays, locator: Any, mapped: NDArray[np.float64]) -> float:
    """E of eq. (3) on the normalised target surface.

    Parameters
    ----------
    p : dict
        The target's stage-1 dict.
    locator : PointLocator
        On its disk.
    mapped : (m, 2) float64
        The source landmarks mapped onto the target disk.

    Returns
    -------
    float
    """
    from conformorph.geometry.registration_error import surface_registration_error

    return surface_registration_error(
        mapped, p["uv"], p["Vn"], p["F"], p["lm_points"], locator=locator
    )


def pair_metrics(pair: KeyPair, reg_d: Any, reg_m: Any) -> dict[str, Any]:
    """E_D (eq. 2), E (eq. 3), folds and the Möbius map of one pair's MT and DMT.

    Parameters
    ----------
    pair : KeyPair
    reg_d, reg_m : DiskRegistration
        The pair's DMT and MT.

    Returns
    -------
    dict
        ``pair, E_D, E, dmt_fallback, dmt_attempts, min_jacobian,
        folded_triangles, mobius``.
    """
    from conformorph.geometry.registration_error import disk_registration_error

    i = pair.index
    P, Q = pair.source["lm_uv"], pair.target["lm_uv"]
    e_dmt = surface_error(pair.target, pair.target_locator, reg_d.apply(P))
    e_mt = surface_error(pair.target, pair.target_locator, reg_m.apply(P))
    return {
        "pair": [i - 1, i],
        "E_D": {"mt": reg_m.error_disk, "dmt": disk_registration_error(reg_d.apply(P), Q)},
        "E": {"mt": e_mt, "dmt": e_dmt},
        "dmt_fallback": reg_d.fallback,
        "dmt_attempts": reg_d.attempts,
        "min_jacobian": {
            "mt": reg_m.fold.min_jacobian_determinant if reg_m.fold else None,
            "dmt": reg_d.fold.min_jacobian_determinant if reg_d.fold else None,
        },
        "folded_triangles": {
            "mt": reg_m.fold.n_folded if reg_m.fold else None,
            "dmt": reg_d.fold.n_folded if reg_d.fold else None,
        },
        "mobius": {
            "a": [reg_m.mobius.a.real, reg_m.mobius.a.imag],
            "theta": reg_m.mobius.theta,
        },
    }
