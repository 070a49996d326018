"""Spherical conformal map of a closed genus-0 mesh by nonlinear heat diffusion (QIEM)."""

from __future__ import annotations

import time
from dataclasses import dataclass
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


def gauss_map(V: FloatArray, F: IntArray) -> FloatArray:
    """Gauss map: unit area-weighted vertex normals of a closed mesh
    (:func:`geometry.vertex_normals.vertex_normals`), none of them vanishing.

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
        :func:`geometry.qiem_disk_map.double_cover_gauss_map`).
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


def spherical_conformal_map(
    V: FloatArray,
    F: IntArray,
    *,
    initial_map: FloatArray | None = None,
    scheme: Scheme = "qiem",
    time_step: float = 0.05,
    max_time_step: float = 10.0,
    min_time_step: float = 1e-8,
    growth: float = 2.0,
    max_iterations: int = 500,
    tol: float = SPHERE_MAP_STEP_TOL,
    center: bool = True,
    mirror: IntArray | None = None,
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
    mirror : (n,) int64, optional
        An involution of the vertices that is a symmetry of the mesh (it maps
        triangles to triangles with reversed orientation and preserves the
        cotangent weights), such as the swap of the two copies of a double
        cover (:attr:`geometry.double_cover.DoubleCover.mirror`). The initial
        map must then satisfy ``φ[mirror] = φ · diag(1, 1, −1)``; the flow
        keeps that symmetry exactly, and every linear solve is split into an
        even (x, y) and an odd (z) half-size system (same iterates, about half
        the cost; the seam, the fixed points of ``mirror``, stays on the
        equator).

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
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise NotTrianglesError(f"V must have shape (n, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or not np.issubdtype(F.dtype, np.integer):
        raise NotTrianglesError(f"F must be an integer array of shape (m, 3), got {F.shape}")
    F = F.astype(np.int64)
    if scheme not in ("qiem", "lagged"):
        raise ValueError(f"scheme must be 'qiem' or 'lagged', got {scheme!r}")
    if not (0 < min_time_step <= time_step <= max_time_step):
        raise ValueError("need 0 < min_time_step <= time_step <= max_time_step")
    if growth < 1.0 or max_iterations < 0 or tol <= 0:
        raise ValueError("need growth >= 1, max_iterations >= 0 and tol > 0")

    if initial_map is None:
        phi = gauss_map(V, F)
    else:
        phi = np.array(initial_map, dtype=np.float64)
        if phi.shape != V.shape:
            raise ValueError(f"initial_map must have shape {V.shape}, got {phi.shape}")
        norm = np.linalg.norm(phi, axis=1, keepdims=True)
        if not np.all(np.isfinite(phi)) or np.any(norm == 0):
            raise ValueError("initial_map must be finite and nonzero in every row")
        phi = phi / norm

    split: _MirrorSolver | None = None
    if mirror is not None:
        mirror = np.asarray(mirror, dtype=np.int64)
        if mirror.shape != (V.shape[0],) or np.any(mirror[mirror] != np.arange(V.shape[0])):
            raise ValueError("mirror must be an involution of the vertices, shape (n,)")
        if np.abs(phi[mirror] - phi * [1.0, 1.0, -1.0]).max() > 1e-9:
            raise ValueError("initial_map is not mirror-symmetric: phi[mirror] != phi * (1, 1, -1)")
        split = _MirrorSolver(mirror)

    M = vertex_areas(V, F)  # barycentric lumped mass
    s = 4.0 * np.pi / M.sum()  # scale to area 4π: L is scale invariant, M scales
    M = M * s
    L = sp.csc_array(cotangent_laplacian(V, F))
    Mdiag = sp.diags_array(M).tocsc()
    if center:
        phi = center_on_sphere(phi, M)

    def energy(p: FloatArray) -> float:
        return float(0.5 * np.einsum("ij,ij->", p, L @ p))

    E = energy(phi)
    energies = [E]
    conformal = [E - _image_area(phi, F)]
    steps: list[float] = []
    dts: list[float] = []
    rejected = 0
    nfact = 0
    dt = float(time_step)
    stop = "max_iterations"
    fixed: tuple[float, Any] | None = None

    def factor(A: sp.csc_array) -> Any:
        return factorize(A, symmetric=True) if split is None else split.factorize(A)

    def solve(fac: Any, r: FloatArray) -> FloatArray:
        return fac.solve(r) if split is None else split.solve(fac, r)

    while len(steps) < max_iterations:
        Lphi = L @ phi
        MD = np.einsum("ij,ij->i", Lphi, phi)  # (M D)_ii = ⟨(Lφ)_i, φ_i⟩
        try:
            if scheme == "qiem":
                # [M + δt (L − M D^(m))] φ^(m+1) = M φ^(m); δt is capped so that
                # M − δt M D stays positive: then the matrix is positive definite
                dt = min(dt, QIEM_DT_SAFETY / max(float((MD / M).max()), 1e-300))
                A = Mdiag + dt * (L - sp.diags_array(MD))
                nfact += 1
                new = solve(factor(sp.csc_array(A)), M[:, None] * phi)
            else:
                # [M + δt L] φ^(m+1) = M (I + δt D^(m)) φ^(m)
                if fixed is None or fixed[0] != dt:
                    nfact += 1
                    fixed = (dt, factor(sp.csc_array(Mdiag + dt * L)))
                new = solve(fixed[1], (M + dt * MD)[:, None] * phi)
            norm = np.linalg.norm(new, axis=1, keepdims=True)
            if np.any(norm <= 1e-300):
                raise SingularSystemError("a vertex was mapped to the origin")
            new = new / norm
        except SingularSystemError:
            new = None
        # energy test before the centring, which is not exactly a Möbius map
        E_new = energy(new) if new is not None else np.inf
        if new is None or E_new > E * (1 + 1e-12):
            rejected += 1
            dt *= 0.5
            if dt < min_time_step:
                stop = "stalled"
                break
            continue
        if center:
            new = center_on_sphere(new, M)
            if mirror is not None:  # remove the round-off asymmetry of the centring
                new = 0.5 * (new + new[mirror] * [1.0, 1.0, -1.0])
            E_new = energy(new)
        step = float(np.abs(new - phi).max())
        phi, E = new, E_new
        energies.append(E)
        conformal.append(E - _image_area(phi, F))
        steps.append(step)
        dts.append(dt)
        if step < tol:
            stop = "converged"
            break
        dt = min(dt * growth, max_time_step)

    info = SphericalMapInfo(
        iterations=len(steps),
        energy_history=np.asarray(energies),
        conformal_energy_history=np.asarray(conformal),
        step_history=np.asarray(steps),
        time_steps=np.asarray(dts),
        rejected_steps=rejected,
        factorizations=nfact,
        scheme=scheme,
        stop_reason=stop,
        seconds=time.perf_counter() - t0,
    )
    return phi, info
