"""Landmark registration of two disk parameterisations: MT, and DMT with a fold guard.

Section 3 of the face morphing paper. ``mt`` is the optimal Möbius
transformation (:mod:`conformorph.geometry.mobius_registration`); ``dmt`` composes it with
the modified thin-plate deformation (:mod:`conformorph.geometry.thin_plate_registration`).
The composed map must stay a bijection of the disk: it is checked on a
triangulation of the source disk (:mod:`conformorph.geometry.map_jacobian`).

Fold policy (documented, never silent): when the DMT map folds a triangle,
the landmark displacement is split into 2, 4, 8, … thin-plate steps along
straight landmark paths and the steps are composed
(:func:`~conformorph.geometry.thin_plate_registration.stepwise_thin_plate_registration`:
still exact at the landmarks, each step close to the identity); if that
still folds at ``max_steps``, the fit is repeated with Tikhonov smoothing of
increasing strength (``fold_regularizations``, no longer exact at the
landmarks); if every attempt folds, ``on_fold="fallback"`` returns the MT map
and ``on_fold="raise"`` raises :class:`~conformorph.geometry.mesh_errors.FoldedMapError`.
The returned diagnostics always say what happened (``fallback``:
``"stepwise"``, ``"regularized"`` or ``"mt"``, and every attempt).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ._typing import FloatArray, IntArray
from .map_jacobian import FoldReport, fold_report
from .mesh_errors import FoldedMapError
from .mobius_registration import MobiusTransform, mobius_registration
from .registration_error import disk_registration_error
from .thin_plate_registration import ComposedDeformation, stepwise_thin_plate_registration

#: Tikhonov strengths tried, in order, when the exact DMT fit folds.
FOLD_REGULARIZATIONS = (5e-3, 5e-2, 5e-1, 5.0)


@dataclass(frozen=True)
class DiskRegistration:
    """A registration map of the unit disk: MT, optionally followed by a thin-plate deformation.

    Attributes
    ----------
    mobius : MobiusTransform
    deformation : ComposedDeformation or None
        None for MT (or after a fallback).
    method : str
        ``"mt"`` or ``"dmt"`` — the map actually returned.
    requested : str
        The method asked for.
    fallback : str or None
        None, ``"stepwise"`` (composed steps), ``"regularized"`` (DMT smoothed
        to avoid a fold, not exact at the landmarks) or ``"mt"`` (every DMT
        attempt folded; MT returned).
    attempts : list of dict
        Every DMT attempt: ``{"steps", "regularization", "n_folded", "min_jacobian"}``
        (plus ``"error"`` for a fit that failed, with NaN figures).
    error_disk_mt, error_disk : float
        E_D (eq. 2) of the MT and of the returned map.
    fold : FoldReport
        Folds of the returned map on the check triangulation.
    check_image : (n, 2) float64 or None
        The returned map applied to the check nodes (``check_uv``), computed for
        the fold check and kept so that callers need not evaluate it again.
    """

    mobius: MobiusTransform
    deformation: ComposedDeformation | None
    method: str
    requested: str
    fallback: str | None
    attempts: list[dict[str, float]] = field(default_factory=list)
    error_disk_mt: float = float("nan")
    error_disk: float = float("nan")
    fold: FoldReport | None = None
    check_image: FloatArray | None = None

    def apply(self, uv: FloatArray) -> FloatArray:
        """Apply the map to points, (p, 2) → (p, 2)."""
        z = self.mobius.apply(uv)
        return z if self.deformation is None else self.deformation.apply(z)


def _dmt_plan(
    regularization: float | None, fold_regularizations: Sequence[float], max_steps: int
) -> list[tuple[int, float | None, str | None]]:
    """The DMT attempts in order: (composed steps, Tikhonov ε, fallback label).

    1, 2, 4, … ≤ ``max_steps`` composed steps at ``regularization``, then one step
    at every stronger ε of ``fold_regularizations``.
    """
    plan: list[tuple[int, float | None, str | None]] = []
    k = 1
    while k <= max_steps:
        plan.append((k, regularization, None if k == 1 else "stepwise"))
        k *= 2
    plan += [
        (1, eps, "regularized")
        for eps in fold_regularizations
        if regularization is None or eps > regularization
    ]
    return plan


def _dmt_attempt(
    Pm: FloatArray,
    Q: FloatArray,
    check: tuple[FloatArray, FloatArray, IntArray],
    n_steps: int,
    eps: float | None,
    kernel_scale: FloatArray | None,
    smoothing: FloatArray | None = None,
) -> tuple[ComposedDeformation | None, FoldReport | None, FloatArray | None, dict[str, float]]:
    """One DMT attempt: the thin-plate fit of MT(P) → Q and its fold report on the check mesh.

    ``check`` is (MT image of the check nodes, check nodes, check triangles). Returns
    the fit (None when it failed), its fold report, the check nodes' images and the
    attempt's record.
    """
    z_mt, check_uv, check_F = check
    try:
        d, infos = stepwise_thin_plate_registration(
            Pm, Q, n_steps, kernel_scale=kernel_scale, regularization=eps, smoothing=smoothing
        )
    except (ValueError, ArithmeticError) as exc:
        # e.g. an intermediate step carried a landmark out of the disk: a failed attempt
        return (
            None,
            None,
            None,
            {
                "steps": float(n_steps),
                "regularization": float("nan") if eps is None else float(eps),
                "n_folded": float("nan"),
                "min_jacobian": float("nan"),
                "error": str(exc),  # type: ignore[dict-item]
            },
        )
    # a step that overshoots can overflow to inf/NaN on far check nodes: that is a
    # failed attempt, counted as folded by fold_report, not a warning for the user
    with np.errstate(over="ignore", invalid="ignore"):
        z_d = d.apply(z_mt)
        rep = fold_report(check_uv, z_d, check_F)
    return (
        d,
        rep,
        z_d,
        {
            "steps": float(n_steps),
            "regularization": infos[0].regularization,
            "n_folded": float(rep.n_folded),
            "min_jacobian": rep.min_jacobian_determinant,
        },
    )


def register_disk_landmarks(
    source_uv: FloatArray,
    target_uv: FloatArray,
    check_uv: FloatArray,
    check_F: IntArray,
    *,
    method: Literal["mt", "dmt"] = "dmt",
    kernel_scale: FloatArray | None = None,
    regularization: float | None = None,
    on_fold: Literal["fallback", "raise"] = "fallback",
    fold_regularizations: Sequence[float] = FOLD_REGULARIZATIONS,
    max_steps: int = 32,
) -> DiskRegistration:
    """Register landmark sets P → Q on the disk by MT or DMT, with a bijectivity check.

    Parameters
    ----------
    source_uv : (m, 2) float64
        Landmarks P on the source disk.
    target_uv : (m, 2) float64
        Landmarks Q on the target disk.
    check_uv : (n, 2) float64
        Nodes of a counter-clockwise triangulation of the source disk on which
        the map is checked for folds (e.g. the consistent mesh).
    check_F : (k, 3) int64
        Its triangles.
    method : {"mt", "dmt"}, default "dmt"
    kernel_scale : (m,) float64, optional
        :math:`\\lambda_1^2/\\lambda_0^2` at the landmarks (thin-plate centres).
    regularization : float, optional
        Tikhonov ε of the first DMT attempt (default: the paper's rule, exact
        fit for n = m centres).
    on_fold : {"fallback", "raise"}, default "fallback"
        What to do when DMT folds at every strength (see module docstring).
    fold_regularizations : sequence of float
        Strengths tried when the stepwise fit still folds.
    max_steps : int, default 32
        Largest number of composed thin-plate steps tried (1, 2, 4, …).

    Returns
    -------
    DiskRegistration

    Raises
    ------
    FoldedMapError
        When ``on_fold="raise"`` and every DMT attempt folds.
    """
    return _register(
        (source_uv, target_uv, check_uv, check_F),
        method,
        kernel_scale,
        regularization,
        (on_fold, fold_regularizations, max_steps),
        None,
    )


@dataclass(frozen=True)
class LandmarkTolerance:
    """How a DMT approximates imprecise landmarks instead of interpolating them.

    Attributes
    ----------
    weights : (m,) float64, optional
        Non-negative landmark weights of the Möbius least-squares fit (e.g.
        confidences); default 1 each (the paper's eq. 2).
    smoothing : (m,) float64, optional
        Per-landmark smoothing Λ of the thin-plate part
        (:func:`~conformorph.geometry.thin_plate_registration.thin_plate_registration`; e.g.
        :func:`conformorph.geometry.landmark_smoothing.discrepancy_smoothing`): a larger Λ_i for
        a less certain landmark. Default: interpolation.
    """

    weights: FloatArray | None = None
    smoothing: FloatArray | None = None


def register_disk_landmarks_tolerant(
    source_uv: FloatArray,
    target_uv: FloatArray,
    check_uv: FloatArray,
    check_F: IntArray,
    tolerance: LandmarkTolerance,
    *,
    kernel_scale: FloatArray | None = None,
    regularization: float | None = None,
    on_fold: Literal["fallback", "raise"] = "fallback",
    fold_regularizations: Sequence[float] = FOLD_REGULARIZATIONS,
    max_steps: int = 32,
) -> DiskRegistration:
    """The DMT of :func:`register_disk_landmarks` approximating its landmarks.

    The Möbius part is the weighted least-squares fit and the thin-plate part the
    smoothing spline of ``tolerance``; the fold guard and its fallbacks are the same
    (a composed step is then smoothed towards its goal too). Parameters as in
    :func:`register_disk_landmarks` (``method="dmt"``), plus ``tolerance``.

    Returns
    -------
    DiskRegistration
        Its ``error_disk`` (E_D at the given landmarks) is no longer ~0.
    """
    return _register(
        (source_uv, target_uv, check_uv, check_F),
        "dmt",
        kernel_scale,
        regularization,
        (on_fold, fold_regularizations, max_steps),
        tolerance,
    )


def _register(
    points: tuple[FloatArray, FloatArray, FloatArray, IntArray],
    method: str,
    kernel_scale: FloatArray | None,
    regularization: float | None,
    policy: tuple[str, Sequence[float], int],
    tolerance: LandmarkTolerance | None,
) -> DiskRegistration:
    """The body of both registrations: MT, then the DMT attempts until one is bijective."""
    source_uv, target_uv, check_uv, check_F = points
    on_fold, fold_regularizations, max_steps = policy
    smoothing = None if tolerance is None else tolerance.smoothing
    if method not in ("mt", "dmt"):
        raise ValueError(f"method must be 'mt' or 'dmt', got {method!r}")
    if on_fold not in ("fallback", "raise"):
        raise ValueError(f"on_fold must be 'fallback' or 'raise', got {on_fold!r}")
    P = np.asarray(source_uv, dtype=np.float64)
    Q = np.asarray(target_uv, dtype=np.float64)
    T, _ = mobius_registration(P, Q, weights=None if tolerance is None else tolerance.weights)
    Pm = T.apply(P)
    e_mt = disk_registration_error(Pm, Q)
    z_mt = T.apply(check_uv)
    rep_mt = fold_report(check_uv, z_mt, check_F)
    if method == "mt":
        return DiskRegistration(T, None, "mt", "mt", None, [], e_mt, e_mt, rep_mt, z_mt)
    attempts: list[dict[str, float]] = []
    for n_steps, eps, label in _dmt_plan(regularization, fold_regularizations, max_steps):
        d, rep, z_d, attempt = _dmt_attempt(
            Pm, Q, (z_mt, check_uv, check_F), n_steps, eps, kernel_scale, smoothing
        )
        attempts.append(attempt)
        if d is not None and rep is not None and z_d is not None and rep.is_bijective:
            return DiskRegistration(
                T,
                d,
                "dmt",
                "dmt",
                label,
                attempts,
                e_mt,
                disk_registration_error(d.apply(Pm), Q),
                rep,
                z_d,
            )
    if on_fold == "raise":
        tried = ", ".join(
            "{} steps, ε={:g}: {} folded".format(
                int(a["steps"]), a["regularization"], a["n_folded"]
            )
            for a in attempts
        )
        raise FoldedMapError(
            f"the DMT registration folds the disk at every regularisation tried ({tried})"
        )
    return DiskRegistration(T, None, "mt", "dmt", "mt", attempts, e_mt, e_mt, rep_mt, z_mt)
