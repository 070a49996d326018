"""Spherical conformal map of a closed genus-0 mesh by nonlinear heat diffusion (QIEM)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .cotangent_laplacian import cotangent_laplacian
from .mesh_errors import NotTrianglesError, SingularSystemError
from .sparse_factor import Factorization, factorize
from .tolerances import SPHERE_MAP_STEP_TOL
from .vertex_areas import vertex_areas
from .vertex_normals import vertex_normals

#: QIEM time steps are capped at this fraction of 1 / max_i D_ii (see below)
QIEM_DT_SAFETY = 0.9

Scheme = Literal["qiem", "lagged"]


@dataclass(frozen=True)
class SphericalMapInfo:
    """Diagnostics of :func:`spherical_conformal_map`.

    Attributes
    ----------
    iterations : int
        Accepted time steps.
    energy_history : (iterations + 1,) float64
        Harmonic (Dirichlet) energy ``E_D = ½ tr(φᵀ L φ)`` of every accepted
        iterate, the initial map first, for the mesh scaled to area 4π.
    conformal_energy_history : (iterations + 1,) float64
        ``E_D − A(φ)`` (A = area of the image triangles); zero exactly for a
        conformal map, positive otherwise.
    step_history : (iterations,) float64
        ``max_i |φ_i^{m+1} − φ_i^m|`` of every accepted step.
    time_steps : (iterations,) float64
        δt of every accepted step (the mesh scaled to area 4π, lumped mass).
    rejected_steps : int
        Steps refused because the energy rose or the system was singular
        (each halves δt).
    factorizations : int
        Sparse factorisations made.
    scheme : str
        ``"qiem"`` or ``"lagged"``.
    stop_reason : str
        ``"converged"`` (step below ``tol``), ``"max_iterations"`` or
        ``"stalled"`` (δt fell below ``min_time_step``).
    seconds : float
        Wall time.
    """

    iterations: int
    energy_history: FloatArray
    conformal_energy_history: FloatArray
    step_history: FloatArray
    time_steps: FloatArray
    rejected_steps: int
    factorizations: int
    scheme: str
    stop_reason: str
    seconds: float


@dataclass(frozen=True)
class SphericalMapOptions:
    """Solver knobs of :func:`spherical_conformal_map`.

    Attributes
    ----------
    scheme : {"qiem", "lagged"}
        ``"qiem"``: the paper's scheme; the matrix changes with ``D`` every
        step, so it is factorised anew every step (and after every δt
        change); δt is capped at ``0.9 / max_i D_ii``, which keeps the
        matrix positive definite (beyond it, steps can flip the map's
        orientation: measured on an ellipsoid with δt = 0.5). ``"lagged"``: ``D`` taken from the previous iterate on the
        right-hand side, ``[M + δt L] φ^(m+1) = M (I + δt D^(m)) φ^(m)``,
        whose matrix is fixed, so one factorisation serves all steps while δt
        is unchanged. Both have the harmonic map (``Lφ = M D φ``) as fixed
        point.
    time_step : float
        Initial δt.
    max_time_step, min_time_step : float
        δt never grows beyond ``max_time_step``; if it must shrink below
        ``min_time_step`` the iteration stops with ``"stalled"``.
    growth : float
        After an accepted step δt is multiplied by ``growth`` (capped); after a
        rejected one (energy increase or singular system) it is halved. For
        ``"lagged"`` use ``growth=1`` to keep a single factorisation.
    max_iterations : int
        Cap on accepted steps.
    tol : float
        Stop when ``max_i |φ_i^{m+1} − φ_i^m| < tol``.
    center : bool
        Apply :func:`center_on_sphere` after every step.

    Defaults: ``scheme="qiem"``, ``time_step=0.05``, ``max_time_step=10``,
    ``min_time_step=1e-8``, ``growth=2``, ``max_iterations=500``,
    ``tol=SPHERE_MAP_STEP_TOL`` (:mod:`conformorph.geometry.tolerances`), ``center=True``.
    """

    scheme: Scheme = "qiem"
    time_step: float = 0.05
    max_time_step: float = 10.0
    min_time_step: float = 1e-8
    growth: float = 2.0
    max_iterations: int = 500
    tol: float = SPHERE_MAP_STEP_TOL
    center: bool = True

    def check(self) -> None:
        """Raise ValueError on an option out of range."""
        if self.scheme not in ("qiem", "lagged"):
            raise ValueError(f"scheme must be 'qiem' or 'lagged', got {self.scheme!r}")
        if not (0 < self.min_time_step <= self.time_step <= self.max_time_step):
            raise ValueError("need 0 < min_time_step <= time_step <= max_time_step")
        if self.growth < 1.0 or self.max_iterations < 0 or self.tol <= 0:
            raise ValueError("need growth >= 1, max_iterations >= 0 and tol > 0")


def gauss_map(V: FloatArray, F: IntArray) -> FloatArray:
    """Gauss map: unit area-weighted vertex normals of a closed mesh
    (:func:`conformorph.geometry.vertex_normals.vertex_normals`), none of them vanishing.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Returns
    -------
    N : (n, 3) float64
        Unit normals, oriented like the faces.

    Raises
    ------
    ValueError
        If a vertex normal vanishes, i.e. its summed face normals are no
        longer than 1e-12 times the largest face's (e.g. on the seam of a
        double cover, whose two sheets have opposite normals; see
        :func:`conformorph.geometry.qiem_disk_map.double_cover_gauss_map`).
    """
    N = vertex_normals(V, F, rtol=1e-12)
    bad = np.flatnonzero(~N.any(axis=1))
    if bad.size:
        raise ValueError(
            f"the vertex normal vanishes at {bad.size} vertices (first {bad[:5].tolist()}); "
            "use another initial map"
        )
    return N


def center_on_sphere(phi: FloatArray, M: FloatArray) -> FloatArray:
    """Gu–Yau normalisation: move the mass centre to the origin, then back onto the sphere.

    Parameters
    ----------
    phi : (n, 3) float64
        Points on the unit sphere. Not modified.
    M : (n,) float64
        Vertex masses (of the source mesh).

    Returns
    -------
    phi : (n, 3) float64
        ``(φ − c) / |φ − c|`` with ``c = Σ M_i φ_i / Σ M_i``. This fixes the
        three non-rotational Möbius degrees of freedom that the harmonic energy
        cannot see, and so prevents the flow from collapsing to a point.

    Notes
    -----
    This is Gu and Yau's normalisation, not an exact Möbius transformation:
    near convergence it can raise the discrete harmonic energy by a relative
    1e-8 or so, which is why :func:`spherical_conformal_map` tests the energy
    decrease before centring. The rotation stays free.
    """
    c = (M[:, None] * phi).sum(axis=0) / M.sum()
    q = phi - c
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _image_area(phi: FloatArray, F: IntArray) -> float:
    """Total signed area of the flat image triangles (sign: normal against the outward direction)."""
    x, y, z = (np.ascontiguousarray(c)[F] for c in phi.T)  # each (m, 3)
    ax, ay, az = x[:, 1] - x[:, 0], y[:, 1] - y[:, 0], z[:, 1] - z[:, 0]
    bx, by, bz = x[:, 2] - x[:, 0], y[:, 2] - y[:, 0], z[:, 2] - z[:, 0]
    nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    outward = nx * x.sum(axis=1) + ny * y.sum(axis=1) + nz * z.sum(axis=1) >= 0
    area = np.sqrt(nx * nx + ny * ny + nz * nz)
    return float(0.5 * (area[outward].sum() - area[~outward].sum()))


class _MirrorSolver:
    """Solves ``A φ = r`` for a mirror-symmetric A and r, by the even/odd split.

    With an involution σ of the vertices that commutes with A (``A[σ][:, σ] =
    A``) and a right-hand side whose x, y columns are even (``r[σ] = r``) and
    z column odd (``r[σ] = −r``), the solution has the same parities, so
    ``φ_xy = E ψ`` with ``(Eᵀ A E) ψ = Eᵀ r_xy`` and ``φ_z = O χ`` with
    ``(Oᵀ A O) χ = Oᵀ r_z``, E and O the even and odd extension matrices.
    Both reduced matrices are symmetric positive definite when A is, and
    about half the size: the same iterates, at about half the cost.
    """

    def __init__(self, mirror: IntArray) -> None:
        N = mirror.shape[0]
        v = np.arange(N)
        rep = np.minimum(v, mirror)
        reps, e_col = np.unique(rep, return_inverse=True)
        self.E = sp.csc_array((np.ones(N), (v, e_col)), shape=(N, reps.size))
        moving = mirror != v
        orbit_reps = np.unique(rep[moving])
        o_col = np.searchsorted(orbit_reps, rep[moving])
        sign = np.where(v[moving] == rep[moving], 1.0, -1.0)
        self.O = sp.csc_array((sign, (v[moving], o_col)), shape=(N, orbit_reps.size))

    def factorize(self, A: sp.csc_array) -> tuple[Factorization, Factorization]:
        Ae = sp.csc_array(self.E.T @ A @ self.E)
        Ao = sp.csc_array(self.O.T @ A @ self.O)
        return factorize(Ae, symmetric=True), factorize(Ao, symmetric=True)

    def solve(self, facs: tuple[Factorization, Factorization], r: FloatArray) -> FloatArray:
        out = np.zeros_like(r)
        out[:, :2] = self.E @ facs[0].solve(self.E.T @ r[:, :2])
        out[:, 2] = self.O @ facs[1].solve(self.O.T @ r[:, 2])
        return out


def _initial_sphere_map(V: FloatArray, F: IntArray, initial_map: FloatArray | None) -> FloatArray:
    """The start of the flow: the Gauss map, or ``initial_map`` with its rows normalised (n, 3)."""
    if initial_map is None:
        return gauss_map(V, F)
    phi = np.array(initial_map, dtype=np.float64)
    if phi.shape != V.shape:
        raise ValueError(f"initial_map must have shape {V.shape}, got {phi.shape}")
    norm = np.linalg.norm(phi, axis=1, keepdims=True)
    if not np.all(np.isfinite(phi)) or np.any(norm == 0):
        raise ValueError("initial_map must be finite and nonzero in every row")
    return np.asarray(phi / norm)


def _mirror_split(mirror: IntArray | None, phi: FloatArray) -> _MirrorSolver | None:
    """The even/odd solver of a checked mirror involution (None without one)."""
    if mirror is None:
        return None
    n = phi.shape[0]
    if mirror.shape != (n,) or np.any(mirror[mirror] != np.arange(n)):
        raise ValueError("mirror must be an involution of the vertices, shape (n,)")
    if np.abs(phi[mirror] - phi * [1.0, 1.0, -1.0]).max() > 1e-9:
        raise ValueError("initial_map is not mirror-symmetric: phi[mirror] != phi * (1, 1, -1)")
    return _MirrorSolver(mirror)


class _HeatFlow:
    """The discrete heat flow of one mesh: L, the lumped mass M (area 4π), the solves.

    ``step`` makes one QIEM or lagged time step (eq. of §2.1) (with the factorisation of the
    lagged matrix kept while δt is unchanged); ``energy`` is ``E_D``.
    """

    def __init__(self, V: FloatArray, F: IntArray, scheme: Scheme, split: _MirrorSolver | None):
        M = vertex_areas(V, F)  # barycentric lumped mass
        s = 4.0 * np.pi / M.sum()  # scale to area 4π: L is scale invariant, M scales
        self.M = M * s
        self.L = sp.csc_array(cotangent_laplacian(V, F))
        self.Mdiag = sp.diags_array(self.M).tocsc()
        self.scheme = scheme
        self.split = split
        self.factorizations = 0
        self._fixed: tuple[float, Any] | None = None

    def energy(self, p: FloatArray) -> float:
        """Harmonic energy ``½ tr(φᵀ L φ)`` of a map (n, 3)."""
        return float(0.5 * np.einsum("ij,ij->", p, self.L @ p))

    def _factor(self, A: sp.csc_array) -> Any:
        self.factorizations += 1
        return factorize(A, symmetric=True) if self.split is None else self.split.factorize(A)

    def _solve(self, fac: Any, r: FloatArray) -> FloatArray:
        return fac.solve(r) if self.split is None else self.split.solve(fac, r)

    def flux(self, phi: FloatArray) -> FloatArray:
        """``(M D)_ii = ⟨(Lφ)_i, φ_i⟩`` of a map (n, 3): the (n,) diagonal of ``M D^(m)``."""
        return np.asarray(np.einsum("ij,ij->i", self.L @ phi, phi))

    def capped_time_step(self, MD: FloatArray, dt: float) -> float:
        """QIEM: δt capped so that ``M − δt M D`` stays positive, hence the matrix
        positive definite (lagged: δt itself)."""
        if self.scheme != "qiem":
            return dt
        return min(dt, QIEM_DT_SAFETY / max(float((MD / self.M).max()), 1e-300))

    def step(self, phi: FloatArray, MD: FloatArray, dt: float) -> FloatArray:
        """One time step from ``phi`` (n, 3), ``MD = flux(phi)``: the new unit map (n, 3).

        Raises SingularSystemError on a singular system or a vertex sent to the origin.
        """
        M, L = self.M, self.L
        if self.scheme == "qiem":
            # [M + δt (L − M D^(m))] φ^(m+1) = M φ^(m)
            A = self.Mdiag + dt * (L - sp.diags_array(MD))
            new = self._solve(self._factor(sp.csc_array(A)), M[:, None] * phi)
        else:
            # [M + δt L] φ^(m+1) = M (I + δt D^(m)) φ^(m)
            if self._fixed is None or self._fixed[0] != dt:
                self._fixed = (dt, self._factor(sp.csc_array(self.Mdiag + dt * L)))
            new = self._solve(self._fixed[1], (M + dt * MD)[:, None] * phi)
        norm = np.linalg.norm(new, axis=1, keepdims=True)
        if np.any(norm <= 1e-300):
            raise SingularSystemError("a vertex was mapped to the origin")
        return np.asarray(new / norm)


@dataclass
class _FlowRecord:
    """Histories of the accepted steps (see :class:`SphericalMapInfo`)."""

    energies: list[float]
    conformal: list[float]
    steps: list[float] = field(default_factory=list)
    dts: list[float] = field(default_factory=list)
    rejected: int = 0
    stop: str = "max_iterations"


def _run_heat_flow(
    flow: _HeatFlow,
    phi: FloatArray,
    F: IntArray,
    mirror: IntArray | None,
    opts: SphericalMapOptions,
) -> tuple[FloatArray, _FlowRecord]:
    """Step the flow until the step falls below ``tol`` (or the caps): step acceptance by
    energy decrease before the centring, δt halved on rejection, grown on acceptance."""
    E = flow.energy(phi)
    rec = _FlowRecord(energies=[E], conformal=[E - _image_area(phi, F)])
    dt = float(opts.time_step)
    while len(rec.steps) < opts.max_iterations:
        MD = flow.flux(phi)
        dt = flow.capped_time_step(MD, dt)
        try:
            new: FloatArray | None = flow.step(phi, MD, dt)
        except SingularSystemError:
            new = None
        # energy test before the centring, which is not exactly a Möbius map
        E_new = flow.energy(new) if new is not None else np.inf
        if new is None or E_new > E * (1 + 1e-12):
            rec.rejected += 1
            dt *= 0.5
            if dt < opts.min_time_step:
                rec.stop = "stalled"
                break
            continue
        if opts.center:
            new = center_on_sphere(new, flow.M)
            if mirror is not None:  # remove the round-off asymmetry of the centring
                new = 0.5 * (new + new[mirror] * [1.0, 1.0, -1.0])
            E_new = flow.energy(new)
        step = float(np.abs(new - phi).max())
        phi, E = new, E_new
        rec.energies.append(E)
        rec.conformal.append(E - _image_area(phi, F))
        rec.steps.append(step)
        rec.dts.append(dt)
        if step < opts.tol:
            rec.stop = "converged"
            break
        dt = min(dt * opts.growth, opts.max_time_step)
    return phi, rec


def spherical_conformal_map(
    V: FloatArray,
    F: IntArray,
    *,
    initial_map: FloatArray | None = None,
    mirror: IntArray | None = None,
    options: SphericalMapOptions | None = None,
) -> tuple[FloatArray, SphericalMapInfo]:
    """Conformal map of a closed genus-0 mesh onto the unit sphere (Gu & Yau's heat flow).

    Minimises the harmonic energy over maps into S² by the nonlinear heat
    diffusion ``dφ/dt = −(Δφ)^∥ = −(Δφ − ⟨Δφ, φ⟩ φ)`` (Yueh et al., §2.1),
    discretised with linear finite elements and stepped by the quasi-implicit
    Euler method (QIEM, Lin et al.)::

        [M + δt (L − M D^(m))] φ^(m+1) = M φ^(m),   D_ii = ⟨(M⁻¹Lφ^(m))_i, φ_i^(m)⟩,

    which is the paper's ``[I + δt(L − D)] φ^(m+1) = φ^(m)`` with the
    Laplace–Beltrami operator ``M⁻¹L`` (cotangent L, lumped mass M) written in
    symmetric form, followed by the projection ``φ_i ← φ_i / |φ_i|`` and the
    mass-centre normalisation :func:`center_on_sphere`.

    Parameters
    ----------
    V : (n, 3) float64
        Vertices of a closed, oriented genus-0 mesh (e.g. a double cover).
        Not modified. Scaled internally to total area 4π, so the time steps
        are dimensionless and the result does not depend on the mesh's scale.
    F : (m, 3) int64
        Triangles. Not modified.
    initial_map : (n, 3) float64, optional
        Initial map onto the sphere (rows are normalised). Default: the Gauss
        map :func:`gauss_map`, as in the paper.
    mirror : (n,) int64, optional
        An involution of the vertices that is a symmetry of the mesh (it maps
        triangles to triangles with reversed orientation and preserves the
        cotangent weights), such as the swap of the two copies of a double
        cover (:attr:`conformorph.geometry.double_cover.DoubleCover.mirror`). The initial
        map must then satisfy ``φ[mirror] = φ · diag(1, 1, −1)``; the flow
        keeps that symmetry exactly, and every linear solve is split into an
        even (x, y) and an odd (z) half-size system (same iterates, about half
        the cost; the seam, the fixed points of ``mirror``, stays on the
        equator).

    options : SphericalMapOptions, optional
        Scheme, time steps, stopping rule, centring (defaults documented
        there).

    Returns
    -------
    phi : (n, 3) float64
        Unit vectors, the spherical map.
    info : SphericalMapInfo

    Raises
    ------
    NotTrianglesError
        On malformed arrays.
    ValueError
        On a bad option, or if the Gauss map is undefined somewhere.

    Notes
    -----
    Preconditions: closed, consistently oriented, genus 0, manifold. Step
    acceptance: a step is refused (and δt halved) if the harmonic energy
    rises by more than 1e-12 relative, which makes the flow monotone.

    References
    ----------
    X. Gu, S.-T. Yau, "Computing conformal structures of surfaces",
    Communications in Information and Systems 2(2) (2002),
    doi:10.4310/CIS.2002.v2.n2.a2.
    M.-H. Yueh, X. D. Gu, W.-W. Lin, C.-T. Wu, S.-T. Yau, "Conformal surface
    morphing with applications on facial expressions" (2016), §2.1,
    arXiv:1504.00097.
    """
    t0 = time.perf_counter()
    opts = SphericalMapOptions() if options is None else options
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise NotTrianglesError(f"V must have shape (n, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or not np.issubdtype(F.dtype, np.integer):
        raise NotTrianglesError(f"F must be an integer array of shape (m, 3), got {F.shape}")
    F = F.astype(np.int64)
    opts.check()
    phi = _initial_sphere_map(V, F, initial_map)
    if mirror is not None:
        mirror = np.asarray(mirror, dtype=np.int64)
    flow = _HeatFlow(V, F, opts.scheme, _mirror_split(mirror, phi))
    if opts.center:
        phi = center_on_sphere(phi, flow.M)
    phi, rec = _run_heat_flow(flow, phi, F, mirror, opts)
    info = SphericalMapInfo(
        iterations=len(rec.steps),
        energy_history=np.asarray(rec.energies),
        conformal_energy_history=np.asarray(rec.conformal),
        step_history=np.asarray(rec.steps),
        time_steps=np.asarray(rec.dts),
        rejected_steps=rec.rejected,
        factorizations=flow.factorizations,
        scheme=opts.scheme,
        stop_reason=rec.stop,
        seconds=time.perf_counter() - t0,
    )
    return phi, info
