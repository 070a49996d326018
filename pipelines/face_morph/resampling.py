"""Stage 2d (section 4 of the face paper): every key's data resampled onto the consistent
mesh through the composite maps, its disk carried to key 0's Möbius frame; the composite
maps' fold check; each key's texture rendered on one atlas layout."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays
from conformorph.pipelines.face_morph.rigid_alignment import RigidAlignment
from conformorph.pipelines.face_morph.textures import MAX_TEXTURE_SIZE


def to_first_disk(
    uv: NDArray[np.float64], inverse_mts: Sequence[Any]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Carry points of key i's disk to key 0's Möbius frame: M_1⁻¹ ∘ … ∘ M_i⁻¹.

    Parameters
    ----------
    uv : (p, 2) float64
        Points on key i's disk.
    inverse_mts : sequence of MobiusTransform
        The inverse optimal Möbius transformations of pairs 1 … i, in order.

    Returns
    -------
    uv : (p, 2) float64
    jacobian : (p,) float64
        |d(uv')/d(uv)|², the factor by which disk areas grow (λ = 3D area /
        disk area is divided by it).
    """
    z = np.asarray(uv, dtype=np.float64)
    jac = np.ones(z.shape[0])
    for M in reversed(list(inverse_mts)):
        jac = jac * M.jacobian_determinant(z)
        z = M.apply(z)
    return z, jac


def safe_conformal_factor(
    X: NDArray[np.float64], F: NDArray[np.int64], uv: NDArray[np.float64]
) -> NDArray[np.float64]:
    """λ of a consistent mesh; one-rings collapsed on the disk get their neighbours' value."""
    from conformorph.geometry import vertex_areas

    A3 = vertex_areas(X, F)
    Auv = vertex_areas(uv, F)
    ok = Auv > 0
    if not ok.all():
        raise ValueError(f"{int((~ok).sum())} consistent-mesh one-rings have zero disk area")
    return np.asarray(A3 / Auv)


def composite_fold_check(
    cm_uv: NDArray[np.float64],
    key_uv: Sequence[NDArray[np.float64]] | NDArray[np.float64],
    cm_F: NDArray[np.int64],
    *,
    refuse: str | None = None,
) -> tuple[list[int], list[float]]:
    """Folds of the composite maps consistent mesh → key i (i ≥ 1), refused when asked.

    Parameters
    ----------
    cm_uv : (n, 2) float64
        The consistent mesh on key 0's disk.
    key_uv : (N+1, n, 2) float64 or sequence of (n, 2) float64
        Every key's disk positions of the consistent nodes (key 0 first).
    cm_F : (f, 3) int64
    refuse : str, optional
        The registration's name: raise when a map folds (the homotopy would sweep
        through a folded correspondence). None: only report.

    Returns
    -------
    n_folded : list of int
        Folded triangles of each map to key 1 … N.
    min_jacobian : list of float
        Their smallest Jacobian determinants.

    Raises
    ------
    FoldedMapError
        With ``refuse``, when some map folds a consistent triangle.
    """
    from conformorph.geometry.map_jacobian import fold_report
    from conformorph.geometry.mesh_errors import FoldedMapError

    reports = [fold_report(cm_uv, key_uv[i], cm_F) for i in range(1, len(key_uv))]
    folds = [r.n_folded for r in reports]
    min_jac = [r.min_jacobian_determinant for r in reports]
    folded = [(i, n) for i, n in enumerate(folds, start=1) if n]
    if refuse is not None and folded:
        raise FoldedMapError(
            "the composite map "
            + ", ".join(
                f"to key {i} (mesh {i}) folds {n} of the {cm_F.shape[0]} consistent-mesh triangles"
                for i, n in folded
            )
            + f" (registration {refuse}); "
            "a local re-solve around the folds did not unfold it; "
            "refusing to emit a folded morph: check the landmarks (order, placement) "
            "and the inputs' disk maps"
        )
    return folds, min_jac


def repair_composite_folds(
    cm_uv: NDArray[np.float64],
    cm_F: NDArray[np.int64],
    cm_b: NDArray[np.int64],
    composite: Sequence[NDArray[np.float64]],
    locators: Sequence[Any],
    prepared: Sequence[Arrays],
) -> tuple[list[NDArray[np.float64]], list[dict[str, Any]]]:
    """Composite maps that fold a few consistent triangles, repaired locally.

    Every map consistent mesh → key i (i ≥ 1) that folds is re-solved around its
    folds by :func:`conformorph.geometry.map_fold_repair.map_fold_repair` (the disk's
    boundary nodes kept on the circle); what was done is reported, and a map the
    repair cannot unfold is left as it is (the fold check then refuses it).

    Parameters
    ----------
    cm_uv : (n, 2) float64
        The consistent mesh on key 0's disk.
    cm_F : (f, 3) int64
    cm_b : (k,) int64
        Its boundary nodes.
    composite : sequence of (n, 2) float64
        The consistent nodes on every key's disk (key 0 first).
    locators : sequence of PointLocator
        On every key's disk.
    prepared : sequence of stage-1 dicts
        Every key's ``F`` and ``Vn`` (diameter-normalised vertices).

    Returns
    -------
    composite : list of (n, 2) float64
        The maps, repaired where they folded.
    repairs : list of dict
        One per map that folded: ``key``, ``folded_triangles`` (count),
        ``triangles`` (the first 20 ids), ``moved_nodes``, ``rings``,
        ``max_disk_displacement`` (disk units), ``max_surface_displacement`` (how far
        a moved node's point on key i moved, in key i's diameters) and ``repaired``.
    """
    from conformorph.geometry.map_fold_repair import map_fold_repair

    fixed = np.zeros(cm_uv.shape[0], dtype=bool)
    fixed[np.asarray(cm_b, dtype=np.int64)] = True
    out = [np.asarray(composite[0])]
    repairs: list[dict[str, Any]] = []
    for i in range(1, len(composite)):
        r = map_fold_repair(cm_uv, composite[i], cm_F, fixed=fixed)
        out.append(r.target_uv)
        if r.folded.size == 0:
            continue
        surface = 0.0
        if r.repaired and r.moved.size:
            p = prepared[i]
            before = locators[i].locate(composite[i][r.moved]).interpolate(p["F"], p["Vn"])
            after = locators[i].locate(r.target_uv[r.moved]).interpolate(p["F"], p["Vn"])
            surface = float(np.linalg.norm(after - before, axis=1).max())
        repairs.append(
            {
                "key": i,
                "folded_triangles": int(r.folded.size),
                "triangles": r.folded[:20].tolist(),
                "moved_nodes": int(r.moved.size),
                "rings": r.rings,
                "max_disk_displacement": r.max_displacement,
                "max_surface_displacement": surface,
                "repaired": r.repaired,
            }
        )
    return out, repairs


@dataclass(frozen=True)
class ResampleInputs:
    """What the resampling of one registration variant reads.

    Attributes
    ----------
    prepared : sequence of stage-1 dicts
    locators : sequence of PointLocator
        On every key's disk.
    rigid : RigidAlignment
    inverse_mts : sequence of MobiusTransform
        Inverse MT of pairs 1 … N.
    cm_uv : (n, 2) float64
    cm_F : (f, 3) int64
    curvature_source : {"consistent", "resampled"}
    """

    prepared: Sequence[Arrays]
    locators: Sequence[Any]
    rigid: RigidAlignment
    inverse_mts: Sequence[Any]
    cm_uv: NDArray[np.float64]
    cm_F: NDArray[np.int64]
    curvature_source: str = "consistent"


def _resample_key(
    src: ResampleInputs, i: int, loc: Any, z_i: NDArray[np.float64], fields: tuple[bool, bool]
) -> dict[str, NDArray[np.float64]]:
    """Key i's data at the consistent nodes located at ``loc`` (disk positions ``z_i``)."""
    from conformorph.geometry import mean_curvature, mean_curvature_vector

    p = src.prepared[i]
    R, tr = src.rigid.rotations[i], src.rigid.translations[i]
    Fi = p["F"]
    uv_i, jac_i = to_first_disk(z_i, src.inverse_mts[:i])
    X_i = loc.interpolate(Fi, p["Vn"]) @ R.T + tr
    d = {"uv": uv_i, "X": X_i}
    if src.curvature_source == "consistent":
        # (H, λ) of the key's consistent mesh (fig. 7 (d), (e)): the discrete
        # representation of the resampled surface on the shared connectivity
        d["Hn"] = mean_curvature_vector(X_i, src.cm_F)
        d["H"] = mean_curvature(X_i, src.cm_F)
        d["lam"] = safe_conformal_factor(X_i, src.cm_F, uv_i)
    else:
        d["Hn"] = loc.interpolate(Fi, p["Hn"]) @ R.T
        d["H"] = loc.interpolate(Fi, p["H"])
        d["lam"] = loc.interpolate(Fi, p["lam"]) / jac_i
    colors, tex = fields
    if colors:
        d["colors"] = loc.interpolate(Fi, p["colors"])
    if tex:
        d["tex_uv"] = loc.interpolate(Fi, p["tex_uv"])
    return d


def resample_keys(
    src: ResampleInputs,
    composite: Sequence[NDArray[np.float64]],
    *,
    identity: bool = False,
    colors: bool = False,
    tex: bool = False,
) -> dict[str, NDArray[np.float64]]:
    """Every key's data on the consistent mesh through one variant's composite maps.

    Disk maps are unique only up to a disk automorphism, and each input's is
    normalised on its own (a reordered copy can come out rotated by 100°); the
    homotopy of disk positions D(q, t) must not sweep through that Möbius
    difference, so key i's disk is carried back by the inverse MTs of pairs
    i, i − 1, …, 1 (λ transforms with it). The disk positions are the composite
    map's own images: a point in the sliver between a boundary chord of key i's
    disk mesh and its arc has no triangle, and its data come from the nearest
    point of the mesh, but moving the point itself onto the chord would fold the
    rim triangles.

    Parameters
    ----------
    src : ResampleInputs
    composite : sequence of (n, 2) float64
        The consistent nodes' positions on every key's disk (key 0: ``cm_uv``).
    identity : bool
        The oracle correspondence of inputs sharing faces: the same (triangle,
        barycentric) in every key as in key 0, and key i's own disk positions there.
    colors, tex : bool
        Also resample vertex colours / texture coordinates.

    Returns
    -------
    dict
        ``uv, X, Hn, H, lam`` (+ ``colors``, ``tex_uv``), each stacked over the keys
        ((N+1, n, 2), (N+1, n, 3), (N+1, n, 3), (N+1, n), (N+1, n), …).
    """
    from conformorph.geometry.threads import map_in_threads

    # identity: the same (triangle, barycentric) in every mesh, the oracle correspondence
    loc0 = src.locators[0].locate(src.cm_uv) if identity else None

    def row(i: int) -> dict[str, NDArray[np.float64]]:
        p = src.prepared[i]
        loc = loc0 if loc0 is not None else src.locators[i].locate(composite[i])
        z_i = loc.interpolate(p["F"], p["uv"]) if identity else composite[i]
        return _resample_key(src, i, loc, z_i, (colors, tex))

    rows = map_in_threads(row, range(len(src.prepared)))  # the keys side by side
    return {k: np.stack([r[k] for r in rows]) for k in rows[0]}


def key_textures(
    out: Arrays, prepared: Sequence[Arrays], key_tex_uv: Sequence[NDArray[np.float64]]
) -> dict[str, Any]:
    """Render every key's texture on the consistent mesh's atlas layout (into ``out``).

    The layout is the first input's texture coordinates at the consistent
    nodes (its own UVs in ``consistent="source"`` mode); the atlas has the
    first texture's size, at most :data:`MAX_TEXTURE_SIZE` texels a side. The
    reported ``coverage`` is the smallest fraction of atlas texels covered by any key.
    """
    from conformorph.geometry.consistent_mesh import resample_texture

    layout = key_tex_uv[0]
    h, w = prepared[0]["texture"].shape[:2]
    f = min(1.0, MAX_TEXTURE_SIZE / max(h, w))
    shape = (max(1, round(h * f)), max(1, round(w * f)))
    atlases, coverage = [], 1.0
    for i, p in enumerate(prepared):
        img = np.asarray(p["texture"], dtype=np.float64) / 255.0
        tex, covered = resample_texture(layout, out["cm_F"], key_tex_uv[i], img, shape)
        atlases.append(np.clip(np.rint(tex * 255.0), 0, 255).astype(np.uint8))
        coverage = min(coverage, float(covered.mean()))  # the least covered key's
    out["cm_tex_uv"] = layout
    out["key_tex_uv"] = np.stack(key_tex_uv)
    out["key_textures"] = np.stack(atlases)
    return {"size": [int(shape[0]), int(shape[1])], "layout": "mesh 0's UVs", "coverage": coverage}
