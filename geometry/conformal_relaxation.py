"""Relaxation of an injective planar map: Newton on a distortion energy (MIPS, or symmetric
Dirichlet), never leaving the injective maps."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np
import scipy.sparse as sp

from ._typing import FloatArray, IntArray
from .beltrami_coefficient import triangle_frames
from .flipped_triangles import max_orientation_step
from .mesh_errors import SingularSystemError
from .sparse_factor import factorize
from .tolerances import RELAXATION_ENERGY_RTOL


@dataclass(frozen=True)
class RelaxationInfo:
    """Diagnostics of :func:`conformal_relaxation`.

    Attributes
    ----------
    iterations : int
        Newton steps taken.
    energy_history : list of float
        Area-weighted mean energy after each step (the first entry is the
        start); MIPS: 2 for a map that is a similarity on every triangle;
        symmetric Dirichlet: 4 for one that is a rotation on every triangle.
    stop_reason : str
        ``"converged"`` (relative energy decrease below ``tol``),
        ``"max_iterations"``, ``"no_descent"`` (the line search found no
        decrease: a local minimum to round-off) or ``"nothing_free"``.
    free_vertices : int
        Free and sliding vertices.
    triangles : int
        Triangles that touch a free vertex (the only ones whose energy changes).
    """

    iterations: int
    energy_history: list[float]
    stop_reason: str
    free_vertices: int
    triangles: int
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


def _reference_inverses(V: FloatArray, F: IntArray) -> tuple[FloatArray, FloatArray]:
    """Inverse edge matrices of the reference triangles in their own planes, and their areas.

    ``P_t = [x1 - x0, x2 - x0]`` written in an orthonormal frame of the triangle's
    plane (2, 2); the map's Jacobian on triangle t is ``J_t = U_t P_t^{-1}`` with
    ``U_t = [u1 - u0, u2 - u0]``.
    """
    if V.shape[1] == 2:
        P = _edge_matrices(V, F)
    else:
        X = triangle_frames(V, F)  # corner 0 at the origin
        P = np.stack([X[:, 1], X[:, 2]], axis=2)
    area = 0.5 * np.abs(P[:, 0, 0] * P[:, 1, 1] - P[:, 0, 1] * P[:, 1, 0])
    return np.asarray(np.linalg.inv(P), dtype=np.float64), np.asarray(area, dtype=np.float64)


def _edge_matrices(uv: FloatArray, F: IntArray) -> FloatArray:
    return np.stack([uv[F[:, 1]] - uv[F[:, 0]], uv[F[:, 2]] - uv[F[:, 0]]], axis=2)


Energy = Literal["mips", "symmetric_dirichlet"]


def mips_energy(uv: FloatArray, F: IntArray, Pinv: FloatArray, area: FloatArray) -> float:
    """Area-weighted sum of ``|J|_F^2 / det J`` (inf if any triangle is not positive)."""
    J = _edge_matrices(uv, F) @ Pinv
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    if np.any(det <= 0):
        return float("inf")
    return float((area * (J**2).sum(axis=(1, 2)) / det).sum())


def symmetric_dirichlet_energy(
    uv: FloatArray, F: IntArray, Pinv: FloatArray, area: FloatArray
) -> float:
    """Area-weighted sum of ``|J|_F^2 + |J^{-1}|_F^2 = |J|_F^2 (1 + det J^{-2})`` (inf if any
    triangle is not positive); 4 per unit area exactly where ``J`` is a rotation."""
    J = _edge_matrices(uv, F) @ Pinv
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    if np.any(det <= 0):
        return float("inf")
    return float((area * (J**2).sum(axis=(1, 2)) * (1.0 + det**-2)).sum())


def _gradient_hessian(
    uv: FloatArray, F: IntArray, Pinv: FloatArray, area: FloatArray, energy: Energy = "mips"
) -> tuple[FloatArray, FloatArray]:
    """Per-triangle gradient (m, 6) and SPD-projected Hessian (m, 6, 6) in the corner coordinates
    ``(u0, v0, u1, v1, u2, v2)``."""
    J = _edge_matrices(uv, F) @ Pinv
    j = J.reshape(-1, 4)  # row-major: j0 = J00, j1 = J01, j2 = J10, j3 = J11
    d = j[:, 0] * j[:, 3] - j[:, 1] * j[:, 2]
    a = (j**2).sum(axis=1)
    c = np.stack([j[:, 3], -j[:, 2], -j[:, 1], j[:, 0]], axis=1)  # ∂d/∂j
    Hd = np.zeros((4, 4))
    Hd[0, 3] = Hd[3, 0] = 1.0
    Hd[1, 2] = Hd[2, 1] = -1.0
    jc = j[:, :, None] * c[:, None, :]
    cc = c[:, :, None] * c[:, None, :]
    eye = np.eye(4)
    if energy == "mips":  # f = a / d
        gj = 2.0 * j / d[:, None] - (a / d**2)[:, None] * c
        Hj = (
            (2.0 / d)[:, None, None] * eye
            - (2.0 / d**2)[:, None, None] * (jc + jc.transpose(0, 2, 1))
            - (a / d**2)[:, None, None] * Hd
            + (2.0 * a / d**3)[:, None, None] * cc
        )
    else:  # f = a (1 + d^-2)
        g1 = 1.0 + d**-2.0
        gj = 2.0 * j * g1[:, None] - (2.0 * a / d**3)[:, None] * c
        Hj = (
            (2.0 * g1)[:, None, None] * eye
            - (4.0 / d**3)[:, None, None] * (jc + jc.transpose(0, 2, 1))
            + (6.0 * a / d**4)[:, None, None] * cc
            - (2.0 * a / d**3)[:, None, None] * Hd
        )
    w, Q = np.linalg.eigh(Hj)
    Hj = (Q * np.maximum(w, 1e-8 * np.abs(w).max(axis=1, keepdims=True))[:, None, :]) @ Q.transpose(
        0, 2, 1
    )
    # j = vec(U Pinv): J_rs = Σ_k U_rk Pinv_ks, U_rk = (u_{k+1} - u_0)_r
    B = np.zeros((F.shape[0], 4, 6))
    for r in range(2):
        for s in range(2):
            row = 2 * r + s
            for k in range(2):
                B[:, row, 2 * (k + 1) + r] += Pinv[:, k, s]
                B[:, row, r] -= Pinv[:, k, s]
    g = np.einsum("mij,mi->mj", B, gj) * area[:, None]
    H = np.einsum("mij,mik,mkl->mjl", B, Hj, B) * area[:, None, None]
    return g, H


def _max_injective_step(uv: FloatArray, d: FloatArray, F: IntArray) -> float:
    """Largest ``α`` with every triangle of ``uv + s d`` positive for all ``s < α``."""
    return max_orientation_step(_edge_matrices(uv, F), _edge_matrices(d, F))


def conformal_relaxation(
    V: FloatArray,
    F: IntArray,
    uv: FloatArray,
    free: IntArray,
    *,
    max_iterations: int = 50,
    tol: float = RELAXATION_ENERGY_RTOL,
    energy: Energy = "mips",
    slide: IntArray | None = None,
    slide_directions: FloatArray | None = None,
) -> tuple[FloatArray, RelaxationInfo]:
    """Move the ``free`` vertices of an injective planar map to lower its conformal distortion.

    Minimises the area-weighted MIPS energy ``Σ_t A_t |J_t|_F² / det J_t`` (the
    conformal AMIPS energy of Hormann and Greiner; ``≥ 2 A_t``, with equality exactly
    where ``J_t`` is a similarity), or with ``energy="symmetric_dirichlet"`` the
    isometric energy ``Σ_t A_t (|J_t|_F² + |J_t^{-1}|_F²)`` (Smith and Schaefer;
    ``≥ 4 A_t``, equality exactly where ``J_t`` is a rotation, and infinite as a
    triangle collapses in any direction, so it also lifts the smallest stretch)
    over the positions of ``free``; the others stay
    where they are. Newton's method with each triangle's Hessian projected onto
    the positive definite matrices (Teran et al. 2005), one sparse factorisation
    per step, and a backtracking line search that starts below the largest step
    keeping every triangle positive (Smith and Schaefer 2015). The energy is
    infinite on flipped triangles, so every iterate stays injective.

    Parameters
    ----------
    V : (n, 3) or (n, 2) float64
        Reference geometry (the surface whose angles the map should keep).
    F : (m, 3) int64
        Triangles, counter-clockwise in ``uv``.
    uv : (n, 2) float64
        Starting map; every triangle that touches a free vertex must be
        positively oriented.
    free : (k,) int64
        Vertices allowed to move.
    max_iterations : int
        Cap on Newton steps.
    tol : float
        Stop when a step lowers the energy by less than this fraction.
    energy : {"mips", "symmetric_dirichlet"}
        The distortion minimised; the symmetric Dirichlet energy is not scale
        invariant, so ``V`` should have the area the map should keep.
    slide : (s,) int64, optional
        Further vertices that move only along a line: vertex ``slide[j]`` stays on
        the line through its start with direction ``slide_directions[j]``
        (boundary vertices on a straight side of the image: they slide along it,
        and cannot pass their neighbours on it, which would flip a triangle).
        Disjoint from ``free``.
    slide_directions : (s, 2) float64, optional
        Those lines' directions (normalised here; not zero).

    Returns
    -------
    uv : (n, 2) float64
        The relaxed map (a new array); vertices outside ``free`` are unchanged.
    info : RelaxationInfo

    Raises
    ------
    ValueError
        If shapes disagree or a triangle touching a free vertex is not positive
        in the starting map.

    References
    ----------
    K. Hormann, G. Greiner, "MIPS: An Efficient Global Parametrization
    Method", Curve and Surface Design (2000);
    J. Smith, S. Schaefer, "Bijective Parameterization with Free Boundaries",
    ACM Trans. Graph. 34(4) (2015), doi:10.1145/2766947.

    Examples
    --------
    A unit right triangle fan whose centre vertex was pushed off its similar position
    moves back (the energy falls to its minimum, 2 per unit area):

    >>> import numpy as np
    >>> V = np.array([[0., 0], [1, 0], [0, 1], [-1, 0], [0, -1]])
    >>> F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    >>> uv = V.copy(); uv[0] = [0.3, 0.2]
    >>> out, info = conformal_relaxation(V, F, uv, np.array([0]))
    >>> bool(np.allclose(out[0], 0, atol=1e-6)), round(info.energy_history[-1], 6)
    (True, 2.0)
    """
    V, F, uv, free = _checked_inputs(V, F, uv, free, energy)
    n = uv.shape[0]
    slide, dirs = _checked_slide(slide, slide_directions, free, n)
    is_free = np.isin(np.arange(n), np.concatenate([free, slide]))
    T = np.flatnonzero(is_free[F].any(axis=1))
    Ft = F[T]
    if (free.size == 0 and slide.size == 0) or T.size == 0:
        return uv, RelaxationInfo(0, [], "nothing_free", int(free.size + slide.size), int(T.size))
    energy_of = mips_energy if energy == "mips" else symmetric_dirichlet_energy
    Pinv, area = _reference_inverses(V, Ft)
    total_area = float(area.sum())
    E = energy_of(uv, Ft, Pinv, area)
    if not np.isfinite(E):
        raise ValueError("the starting map has flipped triangles next to the free vertices")
    unknowns = _Unknowns.of(n, free, slide, dirs, Ft)
    history = [E / total_area]
    stop = "max_iterations"
    it = 0
    for it in range(1, max_iterations + 1):
        d, slope = _newton_direction(uv, Ft, Pinv, area, energy, unknowns)
        found = _line_search(uv, d, slope, E, lambda x: energy_of(x, Ft, Pinv, area), Ft)
        if found is None:
            stop = "no_descent"
            it -= 1
            break
        trial, E_new = found
        decrease = (E - E_new) / E
        uv, E = trial, E_new
        history.append(E / total_area)
        if decrease < tol:
            stop = "converged"
            break
    return uv, RelaxationInfo(it, history, stop, int(free.size + slide.size), int(T.size))


def _checked_inputs(
    V: FloatArray, F: IntArray, uv: FloatArray, free: IntArray, energy: str
) -> tuple[FloatArray, IntArray, FloatArray, IntArray]:
    """V, F, a copy of uv and the sorted free vertices, after the shape and range checks."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    uv = np.array(uv, dtype=np.float64)
    free = np.unique(np.asarray(free, dtype=np.int64))
    n = uv.shape[0]
    if uv.shape != (n, 2) or V.shape[0] != n or V.shape[1] not in (2, 3):
        raise ValueError(
            f"V must be (n, 2|3) and uv (n, 2) with the same n; got {V.shape}, {uv.shape}"
        )
    if free.size and (free[0] < 0 or free[-1] >= n):
        raise ValueError(f"free vertices must lie in 0..{n - 1}")
    if energy not in ("mips", "symmetric_dirichlet"):
        raise ValueError(f"energy must be 'mips' or 'symmetric_dirichlet', got {energy!r}")
    return V, F, uv, free


def _checked_slide(
    slide: IntArray | None, slide_directions: FloatArray | None, free: IntArray, n: int
) -> tuple[IntArray, FloatArray]:
    """The sliding vertices (s,) and their unit directions (s, 2), after the checks."""
    slide = np.zeros(0, dtype=np.int64) if slide is None else np.asarray(slide, dtype=np.int64)
    dirs = (
        np.zeros((0, 2)) if slide_directions is None else np.asarray(slide_directions, np.float64)
    )
    if slide.ndim != 1 or dirs.shape != (slide.size, 2):
        raise ValueError(
            f"slide must be (s,) and slide_directions (s, 2); got {slide.shape}, {dirs.shape}"
        )
    if slide.size and (slide.min() < 0 or slide.max() >= n):
        raise ValueError(f"slide vertices must lie in 0..{n - 1}")
    if np.unique(slide).size != slide.size or np.intersect1d(slide, free).size:
        raise ValueError("slide vertices must be distinct and not free")
    norm = np.linalg.norm(dirs, axis=1)
    if np.any(~(norm > 0)) or not np.all(np.isfinite(dirs)):
        raise ValueError("slide_directions must be finite and non-zero")
    return slide, dirs / norm[:, None]


@dataclass(frozen=True)
class _Unknowns:
    """Local numbering of the unknowns: two per free vertex, then one per sliding vertex;
    corner coordinate c of triangle t is ``coef[t, c]`` times unknown ``corner_dof[t, c]``
    (``keep``: it has one)."""

    free: IntArray
    slide: IntArray
    dirs: FloatArray
    ndof: int
    corner_dof: IntArray  # (m, 6)
    coef: FloatArray  # (m, 6)
    keep: np.ndarray  # (m, 6) bool

    @classmethod
    def of(
        cls, n: int, free: IntArray, slide: IntArray, dirs: FloatArray, Ft: IntArray
    ) -> _Unknowns:
        dof_xy = np.full((n, 2), -1, dtype=np.int64)
        coef_xy = np.zeros((n, 2))
        dof_xy[free] = 2 * np.arange(free.size)[:, None] + np.arange(2)
        coef_xy[free] = 1.0
        dof_xy[slide] = (2 * free.size + np.arange(slide.size))[:, None]
        coef_xy[slide] = dirs
        corner_dof = dof_xy[Ft].reshape(-1, 6)
        ndof = 2 * free.size + slide.size
        return cls(free, slide, dirs, ndof, corner_dof, coef_xy[Ft].reshape(-1, 6), corner_dof >= 0)

    def displacement(self, step: FloatArray, n: int) -> FloatArray:
        """The (n, 2) vertex displacement of an unknowns vector (ndof,)."""
        d = np.zeros((n, 2))
        d[self.free] = step[: 2 * self.free.size].reshape(-1, 2)
        d[self.slide] = step[2 * self.free.size :, None] * self.dirs
        return d


def _newton_direction(
    uv: FloatArray,
    Ft: IntArray,
    Pinv: FloatArray,
    area: FloatArray,
    energy: Energy,
    u: _Unknowns,
) -> tuple[FloatArray, float]:
    """The projected-Newton step ``−H⁻¹ g`` as a displacement (n, 2), and the slope ``g · step``
    (negative: a descent direction, H being positive semi-definite). The per-triangle
    projection can leave H singular (a sliding vertex whose triangles' projected
    Hessians all vanish along its direction: horse → star at 150 points raised
    here): H + μ I is then solved, μ from ``1e-10 · max diag`` up tenfold."""
    g_t, H_t = _gradient_hessian(uv, Ft, Pinv, area, energy)
    g_t = g_t * u.coef
    H_t = H_t * u.coef[:, :, None] * u.coef[:, None, :]
    keep, corner_dof = u.keep, u.corner_dof
    g = np.bincount(corner_dof[keep], weights=g_t[keep], minlength=u.ndof).astype(np.float64)
    pair = keep[:, :, None] & keep[:, None, :]
    rows = np.broadcast_to(corner_dof[:, :, None], H_t.shape)[pair]
    cols = np.broadcast_to(corner_dof[:, None, :], H_t.shape)[pair]
    H = sp.csc_array((H_t[pair], (rows, cols)), shape=(u.ndof, u.ndof))
    scale = float(np.abs(H.diagonal()).max()) or 1.0
    eye = sp.identity(u.ndof, format="csc")
    mu = 0.0
    while True:
        try:
            step_dir = -factorize(H + mu * eye if mu else H, symmetric=True).solve(g)
            break
        except SingularSystemError:
            if mu > 1e-2 * scale:
                raise
            mu = 1e-10 * scale if mu == 0.0 else 10.0 * mu
    return u.displacement(step_dir, uv.shape[0]), float(g @ step_dir)


def _line_search(
    uv: FloatArray,
    d: FloatArray,
    slope: float,
    E: float,
    energy_at: Callable[[FloatArray], float],
    Ft: IntArray,
) -> tuple[FloatArray, float] | None:
    """Backtracking (Armijo, c = 1e-4) from 0.9 times the largest injective step (at most 1):
    the accepted map (n, 2) and its energy, or None when no step down to 1e-12 descends."""
    alpha = min(1.0, 0.9 * _max_injective_step(uv, d, Ft))
    while alpha > 1e-12:
        trial = uv + alpha * d
        E_new = energy_at(trial)
        if E_new <= E + 1e-4 * alpha * slope:
            return trial, E_new
        alpha *= 0.5
    return None
