"""Patches cut open into disks and their mean-value parameterisations (Floater 2003) onto one polygon."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ._typing import BoolArray, FloatArray, IntArray
from .boundary_anchors import _ring_params
from .consistent_boundaries import ConsistentBoundary
from .flip_repair import _vertex_faces
from .mean_value_weights import mean_value_laplacian
from .parameter_overlay import overlay_triangle_count
from .shape_rings import ShapeRings
from .sparse_factor import factorize
from .triangulate_shape import point_inside_ring, triangulate_segments


def _mean_value_map(V: FloatArray, F: IntArray, nb: int, circle: FloatArray) -> FloatArray:
    """Floater's mean-value map with vertices 0..nb−1 pinned to ``circle``."""
    W = sp.csr_array(mean_value_laplacian(V, F))
    n = V.shape[0]
    uv = np.zeros((n, 2))
    uv[:nb] = circle
    if n > nb:
        WI = sp.csc_array(W[nb:][:, nb:])
        rhs = -(W[nb:][:, :nb] @ circle)
        uv[nb:] = factorize(WI, symmetric=False).solve(rhs)
    return uv


def _find(parent: dict[int, int], f: int) -> int:
    """Union-find root with path halving."""
    while parent[f] != f:
        parent[f] = parent[parent[f]]
        f = parent[f]
    return f


def _disk_mesh(
    uid: IntArray,
    copies: dict[int, list[int]],
    cut_edges: set[tuple[int, int]],
    V: FloatArray,
    F: IntArray,
    n_u: int,
) -> tuple[FloatArray, IntArray]:
    """Cut a triangulation open along the cut edges: vertices 0..nb−1 become the disk-ring entries.

    ``uid[i]`` is the triangulation vertex of disk-ring entry i; a vertex with
    several entries (``copies``) is split, each incident triangle getting the
    copy on its side of the cut (the copy whose next ring edge bounds that
    triangle's fan of triangles between cut edges).
    """
    nb = uid.shape[0]
    local = np.full(V.shape[0], -1, dtype=np.int64)
    for i in range(nb):
        local[uid[i]] = i
    local[n_u:] = nb + np.arange(V.shape[0] - n_u)
    Fd = local[F]
    vf = _vertex_faces(F, V.shape[0])
    for u, entries in copies.items():
        if len(entries) < 2:
            continue
        faces = vf[u]
        parent = {f: f for f in faces}
        by_edge: dict[int, list[int]] = {}
        for f in faces:
            for w in F[f]:
                w = int(w)
                if w != u and (min(u, w), max(u, w)) not in cut_edges:
                    by_edge.setdefault(w, []).append(f)
        for fs in by_edge.values():
            for g in fs[1:]:
                parent[_find(parent, g)] = _find(parent, fs[0])
        for i in entries:
            w = int(uid[(i + 1) % nb])
            for f in faces:
                tri = F[f]
                k = int(np.flatnonzero(tri == u)[0])
                if int(tri[(k + 1) % 3]) == w:
                    root = _find(parent, f)
                    for g in faces:
                        if _find(parent, g) == root:
                            kk = int(np.flatnonzero(F[g] == u)[0])
                            Fd[g, kk] = i
                    break
    X = np.zeros((nb + V.shape[0] - n_u, 2))
    X[:nb] = V[uid]
    X[nb:] = V[n_u:]
    return X, Fd


@dataclass(frozen=True)
class PatchMaps:
    """Both shapes' disk patches and their mean-value maps onto one convex polygon.

    Attributes
    ----------
    meshes : list of ((k, 2) float64, (f, 3) int64)
        Per shape, the disk mesh: vertices 0 … nb−1 are the boundary entries,
        then the inner anchors, then the other inner vertices.
    uvs : list of (k, 2) float64
        Per shape, the mean-value parameterisation of its disk mesh.
    circle : (nb, 2) float64
        The polygon: boundary entry i at angle 2π times the mean of the two
        shapes' normalised arc lengths.
    overlay_triangles : int
        Triangles of the overlay of the two parameterisations
        (:func:`conformorph.geometry.parameter_overlay.overlay_triangle_count`).
    """

    meshes: list[tuple[FloatArray, IntArray]]
    uvs: list[FloatArray]
    circle: FloatArray
    overlay_triangles: int


def patch_maps(
    source: ShapeRings,
    target: ShapeRings,
    boundary: ConsistentBoundary,
    hole_match: list[int],
    inner_anchors: FloatArray,
    quality: tuple[int, float],
) -> PatchMaps:
    """Triangulate each shape, cut it open into the disk patch and map it onto the polygon.

    The mean-value map (Floater 2003) of a disk mesh onto a convex polygon is a
    bijection (Floater's theorem); both shapes use the same polygon.

    Parameters
    ----------
    source, target : ShapeRings
    boundary : ConsistentBoundary
    hole_match : list of int
        Target hole of each source hole.
    inner_anchors : (i, 2, 2) float64
        The anchors inside the shapes, inserted as triangulation vertices.
    quality : (int, float)
        ``triangles_per_shape`` (largest triangle area: shape area / this) and
        the minimum angle in degrees of the shape triangulations.

    Returns
    -------
    PatchMaps
    """
    triangles_per_shape, min_angle = quality
    uid, n_u, nb = boundary.uid, boundary.n_u, boundary.nb
    meshes = []
    for B, shape, side, holes in (
        (boundary.Bs, source, 0, list(range(len(hole_match)))),
        (boundary.Bt, target, 1, hole_match),
    ):
        U = np.zeros((n_u, 2))
        U[uid] = B
        V, F = triangulate_segments(
            U,
            boundary.segs,
            hole_points=np.array([point_inside_ring(shape.holes[h]) for h in holes]).reshape(-1, 2),
            points=inner_anchors[:, side],
            max_area=shape.area / triangles_per_shape,
            min_angle=min_angle,
            split_inner_segments=False,
        )
        meshes.append(_disk_mesh(uid, boundary.copies, boundary.cut_edges, V, F, n_u))

    def arcfrac(B: FloatArray) -> FloatArray:
        cum, L = _ring_params(B)
        return np.asarray(cum[:-1] / L, dtype=np.float64)

    ang = 2.0 * np.pi * 0.5 * (arcfrac(boundary.Bs) + arcfrac(boundary.Bt))
    circle = np.c_[np.cos(ang), np.sin(ang)]
    uvs = [_mean_value_map(X, F, nb, circle) for X, F in meshes]
    overlay = overlay_triangle_count(uvs[0], meshes[0][1], uvs[1], meshes[1][1], nb)
    return PatchMaps(meshes, uvs, circle, overlay)


def glue_cut(
    boundary: ConsistentBoundary, F: IntArray, Xd: list[FloatArray], n_in: int
) -> tuple[FloatArray, FloatArray, IntArray, BoolArray]:
    """Close the cut: boundary entries that are copies of one vertex become that vertex.

    Parameters
    ----------
    boundary : ConsistentBoundary
    F : (m, 3) int64
        Triangles of the merged triangulation (boundary entries 0 … nb−1 first,
        then the inner anchors, then the other merged points).
    Xd : list of (k, 2) float64
        Its source and target positions.
    n_in : int
        Number of inner anchors.

    Returns
    -------
    Xs, Xt : (n, 2) float64
        Glued positions; vertices no triangle uses (coincident refinement
        points) are dropped.
    F : (m, 3) int64
    fixed : (n,) bool
        The boundary vertices and the inner anchors.
    """
    uid, n_u = boundary.uid, boundary.n_u
    nb = uid.shape[0]
    k = Xd[0].shape[0]
    glue = np.concatenate([uid, n_u + np.arange(k - nb)])
    F = glue[F]
    n = n_u + k - nb
    Xs, Xt = np.zeros((n, 2)), np.zeros((n, 2))
    Xs[glue], Xt[glue] = Xd[0], Xd[1]
    # drop vertices left unreferenced by coincident refinement points
    referenced = np.zeros(n, dtype=bool)
    referenced[F.ravel()] = True
    referenced[: n_u + n_in] = True
    if not np.all(referenced):
        renum = np.cumsum(referenced) - 1
        F, Xs, Xt, n = renum[F], Xs[referenced], Xt[referenced], int(referenced.sum())
    fixed = np.zeros(n, dtype=bool)
    fixed[: boundary.n_outer + boundary.n_hole] = True
    fixed[n_u : n_u + n_in] = True
    return Xs, Xt, F, fixed
