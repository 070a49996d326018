"""Surface reconstruction from (H, λ) on the disk and the boundary: Algorithm 1 of the face paper."""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from ._typing import FloatArray, IntArray
from .boundary_loop import boundary_loop
from .cotangent_laplacian import cotangent_laplacian
from .fold_correction import fold_correction
from .mesh_errors import MeshError
from .sparse_factor import Factorization, factorize
from .tolerances import RECONSTRUCTION_TOL
from .vertex_areas import vertex_areas
from .vertex_normals import vertex_normals


class NoInteriorVertexError(MeshError):
    """Every vertex of the mesh lies on its boundary (one triangle, an open fan):
    the boundary positions are all of the surface, there is nothing to solve for."""

    code = "no_interior_vertex"


@dataclass(frozen=True)
class ReconstructionOperator:
    """The factorised disk Laplacian of one parameterisation, reusable for many (H, λ).

    Attributes
    ----------
    uv : (n, 2) float64
    F : (m, 3) int64
    b : (k,) int64
        Boundary vertices (Dirichlet data).
    interior : (n - k,) int64
    area_uv : (n,) float64
        Barycentric vertex areas on the disk.
    """

    uv: FloatArray
    F: IntArray
    b: IntArray
    interior: IntArray
    area_uv: FloatArray
    factor: Factorization = field(repr=False)
    L_IB: Any = field(repr=False)

    def solve(self, rhs: FloatArray, boundary_positions: FloatArray) -> FloatArray:
        """Solve ``L_uv X = rhs`` at interior vertices with ``X[b] = boundary_positions``.

        Parameters
        ----------
        rhs : (n, 3) float64
        boundary_positions : (k, 3) float64

        Returns
        -------
        X : (n, 3) float64
        """
        X = np.zeros((self.uv.shape[0], 3))
        X[self.b] = boundary_positions
        X[self.interior] = self.factor.solve(rhs[self.interior] - self.L_IB @ boundary_positions)
        return X


def reconstruction_operator(
    uv: FloatArray, F: IntArray, b: IntArray | None = None
) -> ReconstructionOperator:
    """Factorise the interior cotangent Laplacian of the disk mesh once.

    Parameters
    ----------
    uv : (n, 2) float64
        Disk positions.
    F : (m, 3) int64
    b : (k,) int64, optional
        Boundary (Dirichlet) vertices; default the boundary loop.

    Returns
    -------
    ReconstructionOperator

    Raises
    ------
    NoInteriorVertexError
        If every vertex is a boundary vertex (a single triangle, an open fan).
    """
    uv = np.asarray(uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ValueError(f"uv must have shape (n, 2), got {uv.shape}")
    b = boundary_loop(F) if b is None else np.asarray(b, dtype=np.int64)
    n = uv.shape[0]
    mask = np.ones(n, dtype=bool)
    mask[b] = False
    I = np.flatnonzero(mask)
    if I.size == 0:
        raise NoInteriorVertexError(
            f"reconstruction needs an interior vertex: all {n} vertices of this mesh "
            f"({F.shape[0]} triangles) lie on its boundary, whose positions are given, "
            "so there is nothing to reconstruct"
        )
    L = cotangent_laplacian(uv, F)
    return ReconstructionOperator(
        uv=uv,
        F=F,
        b=b,
        interior=I,
        area_uv=vertex_areas(uv, F),
        factor=factorize(L[I][:, I], symmetric=True),
        L_IB=L[I][:, b],
    )


@dataclass(frozen=True)
class ReconstructionInfo:
    """Diagnostics of :func:`reconstruct_surface`.

    Attributes
    ----------
    mode : str
        ``"vector"`` (one solve with the mean-curvature vector) or
        ``"scalar"`` (Algorithm 1's normal-update iteration).
    iterations : int
    change_history : list of float
        ``max |X^{j+1} − X^j|`` relative to the boundary's bounding-box
        diagonal, per iteration.
    stop_reason : str
        ``"direct"``, ``"converged"`` or ``"max_iterations"``.
    seconds : float
    fold_correction : dict or None
        :class:`conformorph.geometry.fold_correction.FoldCorrectionInfo` as a dict when
        ``correct_folds`` was asked for, else None.
    """

    mode: str
    iterations: int
    change_history: list[float]
    stop_reason: str
    seconds: float
    fold_correction: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class ReconstructionOptions:
    """Solver knobs of :func:`reconstruct_surface`.

    Attributes
    ----------
    max_iterations : int
        Cap on normal updates of Algorithm 1 (scalar H). Default 60.
    warmup_iterations : int
        Initial iterations that use area-weighted vertex normals. Default 10.
    damping : float
        Relaxation ω in ``X ← (1 − ω) X + ω X_new`` after the warm-up, in
        (0, 1]. Default 0.5.
    normal_update : {"curvature_direction", "area"}
        How step 4 of Algorithm 1 updates the normal after the warm-up:
        the direction of the current surface's own mean-curvature vector
        (:func:`curvature_direction_normals`), which is the direction in
        which :func:`conformorph.geometry.mean_curvature` measured H and keeps its
        tangential part (default); or the paper's geometric (area-weighted)
        normal.
    tol : float
        Stop when the relative change falls below this. Default
        :data:`conformorph.geometry.tolerances.RECONSTRUCTION_TOL`.
    correct_folds : bool
        Mean-curvature vector only, and only for a ``uv`` that is the
        surface's discrete harmonic map (the fast method without angle
        refinement or Möbius normalisation, as ``conformorph reconstruct``
        computes it): where ``uv`` folds, finish with
        :func:`conformorph.geometry.fold_correction`, which solves the surface's own
        Laplace equations around the fold (ICT faces: L∞ 3.9e-3–6.2e-3 →
        1.9e-3–2.5e-3, ``benchmarks/bench_reconstruct.py``). Nothing changes
        where ``uv`` does not fold. Default False.
    """

    max_iterations: int = 60
    warmup_iterations: int = 10
    damping: float = 0.5
    normal_update: Literal["curvature_direction", "area"] = "curvature_direction"
    tol: float = RECONSTRUCTION_TOL
    correct_folds: bool = False


def curvature_direction_normals(X: FloatArray, F: IntArray, N: FloatArray) -> FloatArray:
    """Unit normals along the surface's own mean-curvature vector ``L_X X``, signed like ``N``.

    The normal update of step 4 of Algorithm 1 (``normal_update=
    "curvature_direction"``): the direction in which
    :func:`conformorph.geometry.mean_curvature` measures H. Where ``L_X X`` vanishes
    (relative to its largest row, 1e-12) the given normal is kept.

    Parameters
    ----------
    X : (n, 3) float64
        Current surface.
    F : (m, 3) int64
    N : (n, 3) float64
        Unit reference normals (area-weighted vertex normals); they fix the
        sign and fill in where the curvature vector vanishes.

    Returns
    -------
    N : (n, 3) float64
        Unit normals.
    """
    K = cotangent_laplacian(X, F) @ X
    norm = np.linalg.norm(K, axis=1, keepdims=True)
    sign = np.where(np.einsum("ij,ij->i", K, N) < 0, -1.0, 1.0)[:, None]
    ok = norm[:, 0] > 1e-12 * max(float(norm.max()), 1e-300)
    return np.where(ok[:, None], sign * K / np.maximum(norm, 1e-300), N)


def normal_update_iteration(
    op: ReconstructionOperator,
    H: FloatArray,
    area3: FloatArray,
    boundary_positions: FloatArray,
    options: ReconstructionOptions,
) -> tuple[FloatArray, list[float], str]:
    """Algorithm 1 of the face paper: solve eq. 1 for X, update the normal, repeat.

    Each iteration solves ``L_uv X^{j+1} = 2 H λ A_uv n^j`` at interior
    vertices with ``X = boundary`` on ∂D, then takes ``n^{j+1}`` from
    ``X^{j+1}`` (step 4): area-weighted vertex normals for the first
    ``options.warmup_iterations``, then as ``options.normal_update`` says,
    with the damping ω. ``n^(0)`` is the flat disk's normal (+z), so the
    first iterate is the graph-like solution.

    Parameters
    ----------
    op : ReconstructionOperator
        The factorised disk Laplacian.
    H : (n,) float64
        Scalar mean curvature.
    area3 : (n,) float64
        3D vertex areas ``λ A_uv``.
    boundary_positions : (k, 3) float64
        Positions of ``op.b``.
    options : ReconstructionOptions

    Returns
    -------
    X : (n, 3) float64
    change_history : list of float
        ``max |X^{j+1} − X^j|`` relative to the boundary's bounding-box
        diagonal, per iteration.
    stop_reason : str
        ``"converged"`` or ``"max_iterations"``.
    """
    bp = boundary_positions
    F = op.F
    n = op.uv.shape[0]
    diag = float(np.linalg.norm(bp.max(axis=0) - bp.min(axis=0))) or 1.0
    n0 = np.zeros((n, 3))
    n0[:, 2] = 1.0
    X = op.solve(2.0 * (H * area3)[:, None] * n0, bp)
    history: list[float] = []
    stop = "max_iterations"
    for j in range(options.max_iterations):
        N = vertex_normals(X, F)
        if j >= options.warmup_iterations and options.normal_update == "curvature_direction":
            N = curvature_direction_normals(X, F, N)
            omega = options.damping
        else:
            omega = 1.0
        X_new = op.solve(2.0 * (H * area3)[:, None] * N, bp)
        X_new = (1.0 - omega) * X + omega * X_new
        change = float(np.abs(X_new - X).max()) / diag
        history.append(change)
        X = X_new
        if change < options.tol:
            stop = "converged"
            break
    return X, history, stop


def _checked_inputs(
    uv: FloatArray, F: IntArray, H: FloatArray, lam: FloatArray, options: ReconstructionOptions
) -> tuple[FloatArray, IntArray, FloatArray, FloatArray]:
    """The arrays as float64/int64, after the shape, value and option checks."""
    uv = np.asarray(uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    H = np.asarray(H, dtype=np.float64)
    lam = np.asarray(lam, dtype=np.float64)
    n = uv.shape[0]
    if H.shape not in ((n,), (n, 3)):
        raise ValueError(f"H must have shape ({n},) or ({n}, 3), got {H.shape}")
    if lam.shape != (n,):
        raise ValueError(f"lam must have shape ({n},), got {lam.shape}")
    if not (np.all(np.isfinite(H)) and np.all(np.isfinite(lam))):
        raise ValueError("H and lam must be finite")
    if np.any(lam <= 0):
        raise ValueError("the conformal factor lam must be positive")
    if not 0.0 < options.damping <= 1.0:
        raise ValueError(f"damping must lie in (0, 1], got {options.damping}")
    return uv, F, H, lam


def reconstruct_surface(
    uv: FloatArray,
    F: IntArray,
    H: FloatArray,
    lam: FloatArray,
    boundary_positions: FloatArray,
    *,
    b: IntArray | None = None,
    operator: ReconstructionOperator | None = None,
    options: ReconstructionOptions | None = None,
) -> tuple[FloatArray, ReconstructionInfo]:
    """Reconstruct a surface from its (H, λ) representation and boundary (Algorithm 1).

    Solves the discrete Laplace–Beltrami equation (eq. 1)
    ``Δ_uv X = 2 H λ n`` on the disk: with the disk's cotangent Laplacian
    ``L_uv`` (PSD) and barycentric vertex areas ``A_uv``,
    ``L_uv X = 2 H λ A_uv n`` at interior vertices, ``X = boundary`` on ∂D.

    Parameters
    ----------
    uv : (n, 2) float64
        Conformal parameterisation on the unit disk.
    F : (m, 3) int64
    H : (n,) or (n, 3) float64
        Scalar mean curvature (:func:`conformorph.geometry.mean_curvature`) — the
        paper's representation, reconstructed by Algorithm 1's iteration
        (:func:`normal_update_iteration`) — or the mean-curvature vector
        ``H n`` (:func:`geometry.mean_curvature_vector`), reconstructed by
        one solve.
    lam : (n,) float64
        Conformal factor (:func:`conformorph.geometry.conformal_factor`).
    boundary_positions : (k, 3) float64
        3D positions of the boundary vertices ``b``.
    b : (k,) int64, optional
        Boundary vertices; default :func:`conformorph.geometry.boundary_loop`.
    operator : ReconstructionOperator, optional
        A factorisation of this ``uv``'s Laplacian to reuse.
    options : ReconstructionOptions, optional
        Iteration and fold-correction knobs (defaults documented there).

    Returns
    -------
    X : (n, 3) float64
    info : ReconstructionInfo

    Raises
    ------
    NoInteriorVertexError
        If every vertex lies on the boundary (one triangle, an open fan).
    ValueError
        On arrays of the wrong shape, non-finite or non-positive values, or
        ``correct_folds`` with a scalar H.

    Notes
    -----
    Algorithm 1 starts from an unspecified normal ``n^(0)``; we take the
    constant normal of the flat disk (+z), i.e. the first iterate is the
    graph-like solution, then update normals from each iterate. On
    irregular meshes the discrete mean-curvature vector has a large
    tangential part (74 % of its norm on the ICT fill), which a scalar H
    along any geometric normal cannot carry; the vector form keeps it and
    is exact up to replacing the 3D Laplacian by the disk's.
    """
    t0 = time.perf_counter()
    opts = ReconstructionOptions() if options is None else options
    uv, F, H, lam = _checked_inputs(uv, F, H, lam, opts)
    op = operator if operator is not None else reconstruction_operator(uv, F, b)
    bp = np.asarray(boundary_positions, dtype=np.float64)
    if bp.shape != (op.b.size, 3):
        raise ValueError(f"boundary_positions must have shape ({op.b.size}, 3), got {bp.shape}")
    area3 = lam * op.area_uv  # 3D vertex areas, λ A_uv

    if opts.correct_folds and H.ndim != 2:
        raise ValueError(
            "correct_folds needs the mean-curvature vector H (n, 3): the scalar H's normal "
            "loses the tangential part that the fold correction's equations hold"
        )
    if H.ndim == 2:
        rhs = 2.0 * H * area3[:, None]
        X = op.solve(rhs, bp)
        fold_info = None
        if opts.correct_folds:
            X, fc = fold_correction(X, F, uv, rhs, op.b)
            fold_info = fc.to_dict()
        seconds = time.perf_counter() - t0
        return X, ReconstructionInfo("vector", 1, [], "direct", seconds, fold_info)

    X, history, stop = normal_update_iteration(op, H, area3, bp, opts)
    info = ReconstructionInfo("scalar", len(history), history, stop, time.perf_counter() - t0)
    return X, info
