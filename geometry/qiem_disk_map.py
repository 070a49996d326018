"""The paper's route to the disk conformal map: double cover, spherical map by QIEM, projection."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .boundary_loop import boundary_loop
from .cotangent_laplacian import cotangent_laplacian
from .double_cover import DoubleCover, double_cover
from .flipped_triangles import flipped_triangles
from .mobius import normalize_disk_map
from .sparse_factor import Factorization, factorize
from .spherical_conformal_map import (
    Scheme,
    SphericalMapOptions,
    gauss_map,
    spherical_conformal_map,
)
from .stereographic_projection import (
    hemisphere_to_disk,
    inverse_stereographic_projection,
    normalize_boundary_to_circle,
)
from .tolerances import SPHERE_MAP_STEP_TOL
from .validate_mesh import as_mesh_arrays, validate_mesh

InitialMap = Literal["harmonic", "gauss"]


@dataclass(frozen=True)
class QiemInfo:
    """Diagnostics of :func:`qiem_disk_conformal_map` (plain numbers and lists, JSON-ready).

    Attributes
    ----------
    iterations : int
        Accepted heat-flow steps on the sphere.
    stop_reason : str
        Of the spherical flow: ``"converged"``, ``"max_iterations"``,
        ``"stalled"``.
    scheme : str
        ``"lagged"`` or ``"qiem"`` (see
        :func:`conformorph.geometry.spherical_conformal_map`).
    initial_map : str
        ``"harmonic"`` or ``"gauss"``.
    energy_history : list of float
        Harmonic energy of the sphere map per iterate (cover scaled to area 4π).
    conformal_energy_history : list of float
        ``E_D − A`` per iterate (0 for a conformal map).
    rejected_steps, factorizations : int
        Of the spherical flow.
    boundary_deviation : float
        ``max | |uv_b| − 1 |`` after the stereographic projection, before the
        boundary normalisation.
    flipped : int
        Flipped triangles of the returned map.
    seconds : dict of str to float
        Wall time per stage (``cover``, ``initial_map``, ``sphere``,
        ``project``, ``normalize``, ``total``).
    """

    iterations: int
    stop_reason: str
    scheme: str
    initial_map: str
    energy_history: list[float]
    conformal_energy_history: list[float]
    rejected_steps: int
    factorizations: int
    boundary_deviation: float
    flipped: int
    seconds: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class QiemOptions:
    """Knobs of :func:`qiem_disk_conformal_map`'s spherical flow.

    Attributes
    ----------
    initial_map : {"harmonic", "gauss"}
        ``"harmonic"`` (default): :func:`harmonic_hemisphere_map`, a
        degree-one map symmetric under the swap of the two copies; the flow
        keeps that symmetry, so the seam stays on the equator to round-off.
        ``"gauss"``: the paper's Gauss map (:func:`double_cover_gauss_map`).
        Measured on ``choi_human_face``: from the harmonic start the flow
        reaches 1.213° mean angle distortion in 9 steps; from the Gauss map
        (initial harmonic energy 550 times larger, the face's normals fold
        over the sphere) it was still folded after 200 steps (over 12 000
        flipped triangles) with either scheme (``benchmarks/bench_qiem.py``).
    scheme : {"lagged", "qiem"}
        ``"lagged"`` (default) keeps the QIEM matrix fixed and lags D to the
        right-hand side: one factorisation for the whole flow. ``"qiem"`` is
        the paper's scheme, one factorisation per step, with δt capped at
        ``0.9 / max D_ii`` for a positive definite matrix. Same fixed point;
        on ``choi_human_face`` ``"qiem"`` (δt from 0.05, doubling) needed 68
        steps and about seven times as long as ``"lagged"`` (9 steps).
    time_step, growth, max_iterations, tol : float, float, int, float
        Of :class:`conformorph.geometry.spherical_conformal_map.SphericalMapOptions` (δt for
        the cover scaled to area 4π; the default δt = 1 with ``growth=1`` keeps a
        single factorisation; ``max_time_step`` is ``max(time_step, 10)``).
    exploit_symmetry : bool
        With the harmonic start, let the flow use the cover's mirror symmetry
        (``mirror=`` of :func:`conformorph.geometry.spherical_conformal_map`): the same
        iterates to round-off (measured: 2e-14 on ``choi_human_face``), each
        linear system split into two half-size ones, about 25% faster there.

    Defaults: ``initial_map="harmonic"``, ``scheme="lagged"``,
    ``time_step=1``, ``growth=1``, ``max_iterations=200``,
    ``tol=SPHERE_MAP_STEP_TOL``, ``exploit_symmetry=True``.
    """

    initial_map: InitialMap = "harmonic"
    scheme: Scheme = "lagged"
    time_step: float = 1.0
    growth: float = 1.0
    max_iterations: int = 200
    tol: float = SPHERE_MAP_STEP_TOL
    exploit_symmetry: bool = True

    def sphere_options(self) -> SphericalMapOptions:
        """The options of :func:`conformorph.geometry.spherical_conformal_map` for the cover."""
        return SphericalMapOptions(
            scheme=self.scheme,
            time_step=self.time_step,
            max_time_step=max(self.time_step, 10.0),
            growth=self.growth,
            max_iterations=self.max_iterations,
            tol=self.tol,
        )


def harmonic_hemisphere_map(
    V: FloatArray,
    F: IntArray,
    dc: DoubleCover,
    *,
    laplacian: sp.csr_array | None = None,
    interior_factor: Factorization | None = None,
) -> FloatArray:
    """Symmetric initial map of a double cover: a harmonic disk map lifted to both hemispheres.

    Parameters
    ----------
    V : (n, 3) float64
        The disk mesh.
    F : (m, 3) int64
        Its triangles.
    dc : DoubleCover
        Its double cover (``dc.b`` the boundary loop).
    laplacian : (n, n) csr_array, optional
        ``cotangent_laplacian(V, F)``, if already at hand.
    interior_factor : Factorization, optional
        Factorisation of ``L[I][:, I]`` (interior vertices ``I`` in increasing
        order), if already at hand.

    Returns
    -------
    phi0 : (N, 3) float64
        First copy: inverse stereographic projection of the harmonic map with
        the boundary spread over the unit circle by arc length (northern
        hemisphere); second copy: the mirror image ``z ↦ −z`` (southern
        hemisphere). A degree-one map whose seam lies on the equator.
    """
    n = V.shape[0]
    b = dc.b
    seg = np.linalg.norm(V[np.roll(b, -1)] - V[b], axis=1)
    theta = 2.0 * np.pi * np.concatenate([[0.0], np.cumsum(seg)[:-1]]) / seg.sum()
    uv = np.zeros((n, 2))
    uv[b, 0] = np.cos(theta)
    uv[b, 1] = np.sin(theta)
    interior = np.ones(n, dtype=bool)
    interior[b] = False
    inner = np.flatnonzero(interior)
    if inner.size:
        L = sp.csr_array(cotangent_laplacian(V, F) if laplacian is None else laplacian)
        fac = interior_factor
        if fac is None:
            fac = factorize(L[inner][:, inner], symmetric=True)
        uv[inner] = fac.solve(-(L[inner][:, b] @ uv[b]))
    P = inverse_stereographic_projection(uv)
    phi0 = P[dc.source_vertex].copy()
    phi0[dc.second_copy, 2] *= -1.0
    return phi0


def double_cover_gauss_map(V: FloatArray, F: IntArray, dc: DoubleCover) -> FloatArray:
    """Gauss map of a double cover, with the seam sent to the outward conormals.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    dc : DoubleCover

    Returns
    -------
    phi0 : (N, 3) float64
        First copy: unit area-weighted vertex normals; second copy: their
        negatives (the reversed sheet); seam vertices, where the two sheets'
        normals cancel, get the unit outward conormal ``t × n`` of the
        boundary (t the boundary tangent), which lies between the two.

    Raises
    ------
    ValueError
        If a vertex normal of the disk mesh vanishes (:func:`gauss_map`).
    """
    N = gauss_map(V, F)
    b = dc.b
    t = V[np.roll(b, -1)] - V[np.roll(b, 1)]
    co = np.cross(t, N[b])
    co /= np.linalg.norm(co, axis=1, keepdims=True)
    phi0 = N[dc.source_vertex].copy()
    phi0[dc.second_copy] *= -1.0
    phi0[b] = co
    return phi0


def _disk_boundary(
    V: FloatArray, F: IntArray, b: IntArray | None, validate: bool, allow_ears: bool
) -> IntArray:
    """The boundary loop (k,): given, from the validation, or found."""
    if validate:
        report = validate_mesh(V, F, require_disk=True, allow_ears=allow_ears)
        if b is None:
            b = report.boundary
    if b is None:
        b = boundary_loop(F, V)
    return np.asarray(b, dtype=np.int64)


def _interior_laplacian(
    V: FloatArray, F: IntArray, b: IntArray
) -> tuple[sp.csr_array, Factorization | None]:
    """The disk's cotangent Laplacian (n, n) and the factorisation of its interior block
    (None without interior vertices): the harmonic start and the final harmonic
    re-extension share it."""
    L = sp.csr_array(cotangent_laplacian(V, F))
    interior = np.ones(V.shape[0], dtype=bool)
    interior[b] = False
    inner = np.flatnonzero(interior)
    fac = factorize(L[inner][:, inner], symmetric=True) if inner.size else None
    return L, fac


def _sphere_to_disk(
    V: FloatArray,
    F: IntArray,
    phi: FloatArray,
    b: IntArray,
    L: sp.csr_array,
    fac: Factorization | None,
    center_vertex: int | None,
    angle_vertex: int | None,
    seconds: dict[str, float],
) -> tuple[FloatArray, float]:
    """Steps 3–5: the first copy's hemisphere ``phi`` (n, 3) projected to the disk, the
    boundary snapped onto the circle, the Möbius normalisation; the map (n, 2) and the
    projected boundary's ``max | |uv_b| − 1 |`` (``seconds``: ``project``, ``normalize``)."""
    t = time.perf_counter()
    uv = hemisphere_to_disk(phi, F, b)  # step 3
    deviation = float(np.abs(np.hypot(uv[b, 0], uv[b, 1]) - 1.0).max())
    seconds["project"] = time.perf_counter() - t
    t = time.perf_counter()
    uv = normalize_boundary_to_circle(V, F, uv, b, laplacian=L, interior_factor=fac)  # step 4
    if center_vertex is not None or angle_vertex is not None:  # step 5
        uv = normalize_disk_map(uv, b, center_vertex, angle_vertex)
    seconds["normalize"] = time.perf_counter() - t
    return uv, deviation


def qiem_disk_conformal_map(
    V: Any,
    F: Any,
    *,
    b: IntArray | None = None,
    center_vertex: int | None = None,
    angle_vertex: int | None = None,
    validate: bool = True,
    allow_ears: bool = False,
    options: QiemOptions | None = None,
) -> tuple[FloatArray, QiemInfo]:
    """Riemann conformal map of a disk surface by Yueh et al.'s route (§2.1, Fig. 2).

    1. Double covering (:func:`conformorph.geometry.double_cover`): a closed genus-0
       surface.
    2. Spherical conformal map of the cover by the nonlinear heat diffusion
       ``dφ/dt = −(Δφ)^∥`` (:func:`conformorph.geometry.spherical_conformal_map`), with
       the mass-centre normalisation after every step.
    3. Cut at the seam's great circle and stereographic projection of the
       first copy's hemisphere (:func:`~conformorph.geometry.stereographic_projection.hemisphere_to_disk`).
    4. Boundary snapped onto the unit circle, interior re-extended
       harmonically (:func:`~conformorph.geometry.stereographic_projection.normalize_boundary_to_circle`).
    5. Optional Möbius normalisation (:func:`conformorph.geometry.mobius.normalize_disk_map`).

    Parameters
    ----------
    V : (n, 3) array_like of float
        Disk-topology surface. Not modified.
    F : (m, 3) array_like of int
        Triangles. Not modified.
    b : (k,) int64, optional
        Boundary loop (found when not given).
    center_vertex : int, optional
        Vertex sent to 0 by a final disk Möbius transform. Without it the
        Möbius freedom is fixed by the sphere's mass-centre normalisation,
        which does not depend on position, orientation, scale or vertex
        order.
    angle_vertex : int, optional
        Boundary vertex rotated to angle 0.
    validate : bool
        Run :func:`conformorph.geometry.validate_mesh` (disk topology required) first.
    allow_ears : bool
        Passed to the validation.

    options : QiemOptions, optional
        Initial map, scheme, time step and stopping rule of the spherical
        flow (defaults documented there).

    Returns
    -------
    uv : (n, 2) float64
        Disk map, boundary exactly on the unit circle (within 1e-9),
        counter-clockwise. Flipped triangles, if any (e.g. at a folded mouth
        corner), are reported in ``info.flipped``, not repaired.
    info : QiemInfo

    Raises
    ------
    MeshError
        If validation fails.

    References
    ----------
    M.-H. Yueh, X. D. Gu, W.-W. Lin, C.-T. Wu, S.-T. Yau, "Conformal surface
    morphing with applications on facial expressions", §2.1,
    arXiv:1504.00097.
    """
    t0 = time.perf_counter()
    opts = QiemOptions() if options is None else options
    seconds: dict[str, float] = {}
    V, F = as_mesh_arrays(V, F)
    b = _disk_boundary(V, F, b, validate, allow_ears)
    if opts.initial_map not in ("harmonic", "gauss"):
        raise ValueError(f"initial_map must be 'harmonic' or 'gauss', got {opts.initial_map!r}")
    n = V.shape[0]

    t = time.perf_counter()
    dc = double_cover(V, F, b)  # step 1
    seconds["cover"] = time.perf_counter() - t
    t = time.perf_counter()
    L, fac = _interior_laplacian(V, F, b)
    if opts.initial_map == "harmonic":
        phi0 = harmonic_hemisphere_map(V, F, dc, laplacian=L, interior_factor=fac)
    else:
        phi0 = double_cover_gauss_map(V, F, dc)
    seconds["initial_map"] = time.perf_counter() - t

    t = time.perf_counter()
    symmetric = opts.exploit_symmetry and opts.initial_map == "harmonic"
    phi, sinfo = spherical_conformal_map(  # step 2
        dc.V,
        dc.F,
        initial_map=phi0,
        mirror=dc.mirror if symmetric else None,
        options=opts.sphere_options(),
    )
    seconds["sphere"] = time.perf_counter() - t

    uv, deviation = _sphere_to_disk(V, F, phi[:n], b, L, fac, center_vertex, angle_vertex, seconds)
    seconds["total"] = time.perf_counter() - t0
    info = QiemInfo(
        iterations=sinfo.iterations,
        stop_reason=sinfo.stop_reason,
        scheme=opts.scheme,
        initial_map=opts.initial_map,
        energy_history=[float(x) for x in sinfo.energy_history],
        conformal_energy_history=[float(x) for x in sinfo.conformal_energy_history],
        rejected_steps=sinfo.rejected_steps,
        factorizations=sinfo.factorizations,
        boundary_deviation=deviation,
        flipped=int(flipped_triangles(uv, F).sum()),
        seconds=seconds,
    )
    return uv, info
