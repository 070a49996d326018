"""Relaxation of a compatible triangulation's map: the target's free vertices moved to lower its distortion.

The compatible triangulation of :mod:`conformorph.geometry.compatible_triangulation` maps
source to target through two mean-value parameterisations onto one convex polygon.
Where the two shapes differ (a horse's legs against a chair's, a letter's holes against
the seed holes of :func:`conformorph.geometry.hole_seeding.seed_missing_holes`), that
composition squeezes triangles into slivers along the boundary: on the anchor-free pairs of
``benchmarks/bench_outline_matching.py`` horse → chair's map stretched one triangle 40-fold
and shortened one to 0.0019 (largest anisotropy 3,806), B → C's to 0.0055. The strain
morph (eq. 2–4) must carry every triangle's strain to the target's, and from such slivers
its Newton continuation stalls on every scheme. :func:`relaxed_target` moves the target's
free vertices by Newton on the symmetric Dirichlet energy of the map source → target
(:func:`conformorph.geometry.conformal_relaxation.conformal_relaxation`), which is infinite as
a triangle collapses in any direction and never leaves the injective maps; the boundary,
every anchor vertex and the source mesh stay as they are.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ._typing import FloatArray
from .compatible_mesh_quality import min_triangle_angle
from .compatible_triangulation import CompatibleTriangulation
from .conformal_relaxation import RelaxationInfo, conformal_relaxation
from .flip_repair import _areas
from .mesh_edges import mesh_boundary_vertices
from .tolerances import TARGET_RELAX_ENERGY_RTOL

#: Newton steps of :func:`relaxed_target`'s relaxation. On the 19 anchor-free pairs of
#: ``benchmarks/bench_outline_matching.py`` (compatible meshes of 135–600 vertices) it
#: stopped converged (``TARGET_RELAX_ENERGY_RTOL``) well before this.
TARGET_RELAX_MAX_ITERATIONS = 100


def relaxed_target(
    ct: CompatibleTriangulation,
    *,
    max_iterations: int = TARGET_RELAX_MAX_ITERATIONS,
    tol: float = TARGET_RELAX_ENERGY_RTOL,
) -> tuple[CompatibleTriangulation, RelaxationInfo]:
    """The compatible triangulation with its target's free vertices moved to lower the map's distortion.

    Minimises ``Σ_t A_t (|J_t|_F² + |J_t⁻¹|_F²)`` (symmetric Dirichlet; ``J_t``
    the Jacobian of the affine map of triangle t from the source, scaled to the
    target's area so that the optimum keeps area on average, to the target)
    over the target positions of the vertices that are neither on the boundary
    (outer ring and holes) nor an anchor. The source mesh, the triangles and the
    boundary correspondence do not change, so the morph still starts at the
    source and ends at the target shape.

    Parameters
    ----------
    ct : CompatibleTriangulation
        With ``flipped == (0, 0)``.
    max_iterations : int, optional
        Newton steps at most (default ``TARGET_RELAX_MAX_ITERATIONS``).
    tol : float, optional
        Stop when a step lowers the energy by less than this fraction (default
        ``conformorph.geometry.tolerances.TARGET_RELAX_ENERGY_RTOL``).

    Returns
    -------
    CompatibleTriangulation
        ``target_V`` (n, 2) relaxed, ``min_angle`` measured again.
    RelaxationInfo
        Of :func:`conformorph.geometry.conformal_relaxation.conformal_relaxation`
        (``energy_history``: area-weighted mean energy, 4 for a rotation on every triangle).

    Raises
    ------
    ValueError
        If ``ct`` has a flipped triangle, or ``max_iterations`` < 0.

    Examples
    --------
    A square fan whose target centre was pushed aside moves back to the middle:

    >>> import numpy as np
    >>> V = np.array([[0.5, 0.5], [0, 0], [1, 0], [1, 1], [0, 1]])
    >>> F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    >>> W = V.copy(); W[0] = [0.8, 0.3]
    >>> ct = CompatibleTriangulation(V, W, F, np.array([1]), 4, (0, 0), (45.0, 10.0), 0, 0)
    >>> out, info = relaxed_target(ct)
    >>> bool(np.allclose(out.target_V[0], 0.5, atol=1e-6)), info.stop_reason
    (True, 'converged')
    """
    if ct.flipped != (0, 0):
        raise ValueError(f"the compatible triangulation has flipped triangles: {ct.flipped}")
    if max_iterations < 0:
        raise ValueError(f"max_iterations must be at least 0, got {max_iterations}")
    Xs: FloatArray = ct.source_V
    n = Xs.shape[0]
    fixed = mesh_boundary_vertices(ct.F, n)
    fixed[ct.anchor_vertices] = True
    free = np.flatnonzero(~fixed)
    scale = np.sqrt(float(_areas(ct.target_V, ct.F).sum()) / float(_areas(Xs, ct.F).sum()))
    Xt, info = conformal_relaxation(
        Xs * scale,
        ct.F,
        ct.target_V,
        free,
        max_iterations=max_iterations,
        tol=tol,
        energy="symmetric_dirichlet",
    )
    out = replace(
        ct,
        target_V=Xt,
        flipped=(ct.flipped[0], int(np.sum(_areas(Xt, ct.F) <= 0))),
        min_angle=(ct.min_angle[0], min_triangle_angle(Xt, ct.F)),
    )
    return out, info
