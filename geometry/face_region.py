"""The face of a surface that is not a disk, cut out as a disk.

A closed head, a scan with a neck and a back, or a scan with several large
boundary loops holds a face somewhere on it. :func:`face_region` finds it and
cuts it out along a clean boundary:

1. the face's *core*: with landmarks, the faces inside the landmarks' convex
   hull seen from the face's direction (the landmarks' least principal axis),
   joined to every landmark by a shortest path; without them, the faces
   within a radius of the most protruding point (the nose tip) seen from the
   direction where the surface protrudes most sharply (:func:`face_direction`);
2. the *background*: faces farther than ``reach`` times the core's size from
   the core (with landmarks, about where the hairline is above the brows), and
   faces on the surface's own boundary loops;
3. the cut: a minimum cut of the dual graph (faces as nodes, edges weighted
   by their length, much lighter across a crease, heavier near the core)
   between the two, so the boundary is short, follows creases where the
   surface has them (a face glued onto a head), and where it has none (a real
   scan) lies out toward the reach, where the face ends, rather than at the
   landmarks' hull (:func:`_outward_push`);
4. a clean disk: the pieces holding the core, every island of the rest that
   does not reach the background filled in, every bowtie vertex (where the
   region touches itself, or two of its pieces touch) closed by taking its
   whole fan, until the region has one simple boundary loop and Euler
   characteristic 1.

A bound by the surface facing away from the face's direction (smoothed normals
beyond 80–115°, in pieces joined to the far side) was tried and left out: at
80–95° it cut into the ICT face's sides, which face up to 91° away; beyond 105°
it changed nothing on the smooth head and, with a back glued on at a crease,
took the face's own away-facing rim with it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import (
    breadth_first_order,
    connected_components,
    dijkstra,
    maximum_flow,
)
from scipy.spatial import Delaunay, QhullError

from ._face_array import faces_and_vertex_count
from ._typing import BoolArray, FloatArray, IntArray
from .mesh_edges import MeshEdges, mesh_edges
from .mesh_errors import MeshError
from .tolerances import (
    FACE_CUT_CAPACITY_FLOOR,
    FACE_CUT_CREASE_ANGLE,
    FACE_CUT_PUSH,
    FACE_CUT_REACH_LANDMARKS,
    FACE_CUT_REACH_SHAPE,
)


class FaceRegionError(MeshError):
    """No disk-like face region could be cut out of the surface."""

    code = "face_region"


@dataclass(frozen=True)
class FaceDirection:
    """Where a surface's face is, from its shape alone.

    Attributes
    ----------
    tip : int
        The most protruding vertex (the nose tip on a head).
    direction : (3,) float64
        Unit vector from the surface's centroid toward the face.
    slab_fractions : (6,) float64
        For ``+e0, -e0, +e1, -e1, +e2, -e2`` (principal axes, largest spread
        first): the surface area within 5 % of the extent of the extreme point
        along that direction, over the bounding box's cross-section there.
        The face is the direction with the smallest (the sharpest protrusion).
    """

    tip: int
    direction: FloatArray
    slab_fractions: FloatArray


@dataclass(frozen=True)
class FaceRegion:
    """A face cut out of a surface as a disk.

    Attributes
    ----------
    face_mask : (m,) bool
        The input faces kept.
    vertex_map : (n2,) int64
        Input row of every output vertex, increasing.
    F : (m2, 3) int64
        The kept faces re-indexed to ``vertex_map`` (``V[vertex_map]`` are
        their vertices). One boundary loop, Euler characteristic 1.
    centre : int
        Input vertex at the face's centre (the landmark nearest the landmarks'
        centroid in the frontal plane, or the nose tip found by
        :func:`face_direction`).
    from_landmarks : bool
        Whether landmarks placed the core.
    core_faces, background_faces : int
        Faces forced into and out of the region before the cut.
    boundary_edges : int
        Edges on the output's boundary loop.
    boundary_crease_deg : float
        Median angle between the normals of the two faces of each boundary
        edge in the input (near 0 where the cut crosses smooth surface).
    filled_islands, bowtie_fans : int
        Clean-up: islands of the rest filled in, fans added at bowtie vertices.
    """

    face_mask: BoolArray
    vertex_map: IntArray
    F: IntArray
    centre: int
    from_landmarks: bool
    core_faces: int
    background_faces: int
    boundary_edges: int
    boundary_crease_deg: float
    filled_islands: int
    bowtie_fans: int


def _face_normals(V: FloatArray, F: IntArray) -> tuple[FloatArray, FloatArray]:
    """Unit normals (m, 3) and areas (m,) of the faces."""
    c = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    a = np.linalg.norm(c, axis=1)
    return c / np.maximum(a, np.finfo(float).tiny)[:, None], 0.5 * a


def _dual_edges(E: MeshEdges, m: int) -> tuple[IntArray, IntArray]:
    """Pairs of faces (k, 2) sharing an edge used by exactly two faces, and those edges (k,)."""
    he_edge = E.halfedge_edge.reshape(-1)
    he_face = np.repeat(np.arange(m, dtype=np.int64), 3)
    order = np.argsort(he_edge, kind="stable")
    he_edge, he_face = he_edge[order], he_face[order]
    two = np.flatnonzero(E.face_count == 2)
    start = np.searchsorted(he_edge, two)
    return np.stack([he_face[start], he_face[start + 1]], axis=1), two


def _vertex_graph(V: FloatArray, E: MeshEdges, n: int) -> sp.csr_array:
    """Edge graph weighted by edge length, for Dijkstra distances."""
    i, j = E.edges[:, 0], E.edges[:, 1]
    w = np.maximum(np.linalg.norm(V[i] - V[j], axis=1), np.finfo(float).tiny)
    return sp.csr_array(
        (np.concatenate([w, w]), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(n, n)
    )


def face_direction(V: Any, F: Any) -> FaceDirection:
    """The face's direction and nose tip of a head-like surface, from its shape alone.

    Parameters
    ----------
    V : (n, 3) array_like of float
    F : (m, 3) array_like of int

    Returns
    -------
    FaceDirection

    Raises
    ------
    ValueError
        Wrong shapes, non-finite coordinates, indices out of range.

    Notes
    -----
    Candidates are the six directions along the principal axes of the
    vertices; along each, the extreme vertex and the area of the surface
    within a slab of 5 % of the extent behind it. A nose is a small, sharp
    protrusion: its slab holds little area, where the back or the top of a
    head (round) and the base of a neck (flat) hold much more. Ears and other
    sharp protrusions can fool it; landmarks, where known, are better.
    """
    V, F = _checked(V, F)
    centroid = V.mean(axis=0)
    _, _, Wt = np.linalg.svd(V - centroid, full_matrices=False)
    _, area = _face_normals(V, F)
    fc = V[F].mean(axis=1)
    fractions = np.zeros(6)
    tips = np.zeros(6, dtype=np.int64)
    for k in range(6):
        d = Wt[k // 2] * (1.0 if k % 2 == 0 else -1.0)
        h = (V - centroid) @ d
        others = [Wt[i] for i in range(3) if i != k // 2]
        cross = np.prod([np.ptp(V @ o) for o in others])
        depth = 0.05 * float(np.ptp(h))
        slab = ((fc - centroid) @ d) > h.max() - depth
        tips[k] = int(np.argmax(h))
        fractions[k] = float(area[slab].sum()) / max(float(cross), np.finfo(float).tiny)
    best = int(np.argmin(fractions))
    direction = Wt[best // 2] * (1.0 if best % 2 == 0 else -1.0)
    return FaceDirection(int(tips[best]), direction, fractions)


def _checked(V: Any, F: Any) -> tuple[FloatArray, IntArray]:
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3 or V.shape[0] == 0:
        raise ValueError(f"V must be a non-empty (n, 3) array, got {V.shape}")
    if not np.all(np.isfinite(V)):
        raise ValueError("V has non-finite coordinates")
    F, _ = faces_and_vertex_count(F, V.shape[0])
    return V, F


def _landmark_core(
    V: FloatArray, F: IntArray, G: sp.csr_array, ids: IntArray
) -> tuple[BoolArray, int, float]:
    """Core faces, centre vertex and size from the landmarks (see :func:`face_region`)."""
    P = V[ids]
    c = P.mean(axis=0)
    _, _, Wt = np.linalg.svd(P - c, full_matrices=False)
    plane = Wt[:2]
    P2, X2 = (P - c) @ plane.T, (V - c) @ plane.T
    centre = int(ids[np.argmin(np.linalg.norm(P2, axis=1))])
    try:
        inside = Delaunay(P2).find_simplex(X2) >= 0
    except QhullError as exc:
        raise FaceRegionError("the landmarks lie on a line: they span no face region") from exc
    size = float(np.sqrt((np.linalg.norm(P2, axis=1) ** 2).mean()))
    piece = _front_piece(F, inside, centre)
    # join every landmark to the centre by a shortest path
    _, pred = dijkstra(G, indices=centre, return_predecessors=True)
    for t in ids:
        v = int(t)
        if pred[v] < 0 and v != centre:
            raise FaceRegionError(f"landmark vertex {v} is not connected to the face's centre")
        while v >= 0 and not piece[v]:
            piece[v] = True
            v = int(pred[v])
    return piece[F].sum(axis=1) >= 2, centre, size


def _front_piece(F: IntArray, inside: BoolArray, centre: int) -> BoolArray:
    """Vertices (n,) of the piece of faces inside a frontal outline that holds ``centre``.

    Seen from the front the outline covers the back of a head too; the piece
    at the centre is the front.
    """
    in_faces = inside[F].all(axis=1)
    piece = np.zeros(inside.size, dtype=bool)
    if in_faces.any() and inside[centre]:
        _, lab = connected_components(_face_vertex_graph(F[in_faces], inside.size), directed=False)
        piece = inside & (lab == lab[centre])
    piece[centre] = True
    return piece


def _shape_core(V: FloatArray, F: IntArray) -> tuple[BoolArray, int, float]:
    """Core faces, centre and size from the shape alone (see :func:`face_region`)."""
    fd = face_direction(V, F)
    W = np.linalg.svd(V - V.mean(axis=0), full_matrices=False)[2]
    across = [float(np.ptp(V @ w)) for w in W if abs(float(w @ fd.direction)) < 0.5]
    size = 0.4 * min(across) if across else 0.2 * float(np.ptp(V))
    X = V - V[fd.tip]
    X -= np.outer(X @ fd.direction, fd.direction)
    piece = _front_piece(F, np.linalg.norm(X, axis=1) <= size, fd.tip)
    core: BoolArray = np.asarray(piece[F].all(axis=1))
    return core, fd.tip, size


def _place_core(
    V: FloatArray, F: IntArray, G: sp.csr_array, landmark_ids: Any
) -> tuple[BoolArray, int, float]:
    """Core faces (m,), centre vertex and size: :func:`_landmark_core` with landmarks
    (validated here), :func:`_shape_core` without."""
    if landmark_ids is None:
        core, centre, size = _shape_core(V, F)
    else:
        n = V.shape[0]
        ids = np.unique(np.asarray(landmark_ids, dtype=np.int64).reshape(-1))
        if ids.size and (ids.min() < 0 or ids.max() >= n):
            raise ValueError(f"landmark ids must be in 0..{n - 1}")
        if ids.size < 3:
            raise FaceRegionError(f"a face region needs at least 3 landmarks, got {ids.size}")
        core, centre, size = _landmark_core(V, F, G, ids)
    if not core.any():
        core = np.asarray(np.isin(F, [centre]).any(axis=1))
    return core, centre, size


def _face_vertex_graph(F: IntArray, n: int) -> sp.csr_array:
    """Vertex adjacency of the faces ``F``."""
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    return sp.csr_array((np.ones(i.size), (i, j)), shape=(n, n))


def _min_cut(
    m: int, pairs: IntArray, weight: FloatArray, core: BoolArray, background: BoolArray
) -> BoolArray:
    """Faces on the core's side of a minimum cut of the dual graph (capacities ``weight``)."""
    budget = 2**29  # integer capacities (scipy's maximum_flow) whose sum fits in int32
    cap = np.maximum(np.rint(weight / weight.sum() * budget), 1).astype(np.int64)
    big = np.int64(2**30)
    s, t = m, m + 1
    src = np.flatnonzero(core)
    snk = np.flatnonzero(background)
    rows = np.concatenate([pairs[:, 0], pairs[:, 1], np.full(src.size, s), snk])
    cols = np.concatenate([pairs[:, 1], pairs[:, 0], src, np.full(snk.size, t)])
    vals = np.concatenate([cap, cap, np.full(src.size + snk.size, big)]).astype(np.int32)
    C = sp.csr_matrix((vals, (rows, cols)), shape=(m + 2, m + 2))
    C.sum_duplicates()
    flow = maximum_flow(C, s, t, method="dinic").flow
    R = (C - flow).tocsr()
    R.data = (R.data > 0).astype(np.int32)
    R.eliminate_zeros()
    reached = breadth_first_order(R, s, directed=True, return_predecessors=False)
    side = np.zeros(m + 2, dtype=bool)
    side[reached] = True
    return side[:m]


def _components(pairs: IntArray, mask: BoolArray) -> IntArray:
    """Labels (m,) of the edge-connected pieces of the faces in ``mask`` (-1 outside)."""
    m = mask.size
    keep = mask[pairs[:, 0]] & mask[pairs[:, 1]]
    p = pairs[keep]
    A = sp.coo_array((np.ones(p.shape[0]), (p[:, 0], p[:, 1])), shape=(m, m))
    _, lab = connected_components(A, directed=False)
    return np.where(mask, lab, -1)


def _clean_disk(
    F: IntArray, pairs: IntArray, kept: BoolArray, core: BoolArray, background: BoolArray
) -> tuple[BoolArray, int, int]:
    """The pieces at the core, islands of the rest filled, bowtie fans closed (see module)."""
    n = int(F.max()) + 1
    islands = fans = 0
    for _ in range(100):
        lab = _components(pairs, kept)
        kept = np.isin(lab, lab[core & kept])  # every piece holding core faces
        rest = _components(pairs, ~kept)
        outer = np.unique(rest[background & ~kept])
        island = ~kept & ~np.isin(rest, outer)
        islands += len(np.unique(rest[island]))
        kept = kept | island
        E = mesh_edges(F[kept])
        be_v = np.bincount(E.boundary.reshape(-1), minlength=n)
        bowtie = np.flatnonzero(be_v > 2)
        if not bowtie.size:
            return kept, islands, fans
        fans += bowtie.size
        kept = kept | np.isin(F, bowtie).any(axis=1)
        if (kept & background).any():
            raise FaceRegionError(
                "the face region cannot be closed into a disk: it touches itself where it "
                "meets the background"
            )
    raise FaceRegionError("the face region's boundary did not become a simple loop")


def face_region(
    V: Any,
    F: Any,
    landmark_ids: Any = None,
    *,
    reach: float | None = None,
    crease_angle: float = FACE_CUT_CREASE_ANGLE,
    push: float = FACE_CUT_PUSH,
) -> FaceRegion:
    """The face of a closed or many-looped surface, cut out as a disk.

    Parameters
    ----------
    V : (n, 3) array_like of float
    F : (m, 3) array_like of int
        A consistently oriented, edge-manifold triangle mesh (closed, or with
        any number of boundary loops).
    landmark_ids : (k,) array_like of int, optional
        Vertex ids of face landmarks (k ≥ 3, not all on a line); all end up
        inside the region. Without them the face is found from the shape
        (:func:`face_direction`).
    reach : float, keyword-only, optional
        Faces farther (along edges) than ``reach`` times the core's size from
        the core belong to the background, and the cut is pushed out toward
        that distance. The core's size is the landmarks' RMS distance from
        their centroid in the frontal plane; without landmarks, 0.4 times the
        surface's narrower extent across the face direction, which is also the
        radius of the core around the nose tip in the frontal plane. Default
        ``FACE_CUT_REACH_LANDMARKS`` (1.2: for the 68-point layout, whose RMS
        size is about 0.62 inter-ocular distances, 0.75 of them above the brows,
        about where the hairline is) or ``FACE_CUT_REACH_SHAPE`` (1.35).
    crease_angle : float, keyword-only, default ``FACE_CUT_CREASE_ANGLE``
        Radians. An edge whose faces' normals differ by θ weighs
        ``length · (exp(-(θ / crease_angle)²) + FACE_CUT_CAPACITY_FLOOR)`` in the cut.
    push : float, keyword-only, default ``FACE_CUT_PUSH``
        An edge's weight is also multiplied by ``1 + push · max(0, 1 - d / (reach ·
        size))`` for its distance ``d`` from the core: 0 leaves the shortest cut.

    Returns
    -------
    FaceRegion

    Raises
    ------
    ValueError
        Wrong shapes, non-finite coordinates, indices out of range, a landmark
        id out of range, ``reach`` or ``crease_angle`` not positive, ``push``
        negative.
    FaceRegionError
        Fewer than 3 landmarks or landmarks on a line; no face lies farther
        than the reach from the core (nothing to cut away); the region cannot
        be made a disk (e.g. a handle inside it).

    Notes
    -----
    What the cut chooses, and why. A face scan is what a frontal scanner sees:
    the surface facing the camera from the hairline to the jaw, ears and back
    of the head left out. Where a face was glued onto a head, a crease marks
    that outline and the cut follows it. On a real scan nothing does: the
    shortest loop around the core would hug the landmarks' hull (cutting the
    forehead and cheeks away; 96× the clean pair's error on
    ``bench_scan_inputs.py``'s ``smooth_closed``). So the region is bounded by
    where the face ends, not by where the loop is shortest: the reach, from the
    landmarks' size (the hairline above the brows), and the push moves the cut
    out toward it, against its length (:func:`_outward_push`). On a smooth head
    the region then holds all of the face and some of the surface around it
    (on ``smooth_closed``, the ICT face and about 4 % more vertices around it:
    the forehead's top, behind the jaw's sides, under the chin).

    The cut is a minimum s–t cut of the dual graph (faces as nodes, an edge's
    weight as the capacity across it), solved with scipy's Dinic maximum
    flow on integer capacities; the region is the part of the faces that the
    residual graph reaches from the core.

    Examples
    --------
    A unit sphere of 13 latitude rings; the landmarks around the north pole
    place the face there, and everything far from it is cut away:

    >>> from scipy.spatial import ConvexHull
    >>> t, p = np.linspace(0, np.pi, 15)[1:-1], np.linspace(0, 2 * np.pi, 24, endpoint=False)
    >>> T, P = (a.ravel() for a in np.meshgrid(t, p, indexing="ij"))
    >>> V = np.c_[np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)]
    >>> V = np.vstack([[0, 0, 1], V, [0, 0, -1]])
    >>> F = ConvexHull(V).simplices
    >>> N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    >>> F = np.where(((N * V[F].mean(axis=1)).sum(axis=1) < 0)[:, None], F[:, ::-1], F)
    >>> lm = [0, 1, 8, 16, 25]  # the pole and four vertices of the first two rings
    >>> r = face_region(V, F, lm)
    >>> bool(np.isin(lm, r.vertex_map).all()), bool(V[r.vertex_map, 2].min() > 0)
    (True, True)
    >>> r.F.shape[0] < F.shape[0], r.filled_islands, r.bowtie_fans
    (True, 0, 0)
    """
    V, F = _checked(V, F)
    if reach is None:
        reach = FACE_CUT_REACH_SHAPE if landmark_ids is None else FACE_CUT_REACH_LANDMARKS
    if not reach > 0 or not crease_angle > 0 or not push >= 0:
        raise ValueError(
            "reach and crease_angle must be positive and push non-negative, "
            f"got {reach}, {crease_angle}, {push}"
        )
    n, m = V.shape[0], F.shape[0]
    E = mesh_edges(F)
    G = _vertex_graph(V, E, n)
    core, centre, size = _place_core(V, F, G, landmark_ids)
    d = dijkstra(G, indices=np.unique(F[core]), min_only=True)
    pairs, inner = _dual_edges(E, m)
    background = _background(F, E, core, d, reach * size)
    theta = _dihedral(V, F, pairs)
    weight = _cut_weights(V, E.edges[inner], theta, d, crease_angle, (reach * size, push))
    kept = _min_cut(m, pairs, weight, core, background)
    kept, islands, fans = _clean_disk(F, pairs, kept | core, core, background)
    counts = (int(core.sum()), int(background.sum()), islands, fans)
    return _region(V, F, kept, pairs, theta, centre, landmark_ids is not None, counts)


def _background(
    F: IntArray, E: MeshEdges, core: BoolArray, d: FloatArray, far_at: float
) -> BoolArray:
    """Faces (m,) beyond ``far_at`` from the core (distances ``d`` (n,)) or on the
    surface's boundary, less the core; raises when there are none."""
    background = (d[F].min(axis=1) > far_at) | np.isin(F, E.boundary).any(axis=1)
    background &= ~core
    if not background.any():
        raise FaceRegionError(
            f"no part of the surface lies farther than {far_at:.3g} from the face "
            "(along the surface): nothing to cut away around it"
        )
    return np.asarray(background)


def _cut_weights(
    V: FloatArray,
    ev: IntArray,
    theta: FloatArray,
    d: FloatArray,
    crease_angle: float,
    push_to: tuple[float, float],
) -> FloatArray:
    """Capacities (k,) of the interior edges ``ev`` (k, 2) with dihedral angles
    ``theta``: length, lighter across a crease, heavier near the core (see
    :func:`face_region`)."""
    length = np.linalg.norm(V[ev[:, 0]] - V[ev[:, 1]], axis=1)
    weight = length * (np.exp(-((theta / crease_angle) ** 2)) + FACE_CUT_CAPACITY_FLOOR)
    far_at, push = push_to
    return np.asarray(weight * _outward_push(0.5 * (d[ev[:, 0]] + d[ev[:, 1]]), far_at, push))


def _dihedral(V: FloatArray, F: IntArray, pairs: IntArray) -> FloatArray:
    """Angles (k,) between the normals of the face pairs ``pairs`` (radians)."""
    N, _ = _face_normals(V, F)
    return np.arccos(np.clip((N[pairs[:, 0]] * N[pairs[:, 1]]).sum(axis=1), -1.0, 1.0))


def _outward_push(dist: FloatArray, reach: float, push: float) -> FloatArray:
    """Factor (k,) on the cut's edge weights: ``1 + push · max(0, 1 - dist / reach)``.

    Cutting next to the core costs ``1 + push`` times an edge's length, cutting at
    the reach once: on a smooth head the shortest loop around the core would hug it
    (the face cut at the landmarks' hull, losing forehead and cheeks); the push
    moves the cut out toward the reach, where the face ends. A crease still wins:
    its weight is ``exp(-(θ / crease_angle)²)`` of its length (0.06 at 50°), far
    below the push's ratio.

    Parameters
    ----------
    dist : (k,) float64
        Surface distance of each edge's midpoint from the core.
    reach : float
        Distance of the background from the core (> 0).
    push : float
        ≥ 0; 0 leaves every factor 1 (the shortest cut).

    Returns
    -------
    (k,) float64

    Examples
    --------
    >>> _outward_push(np.array([0.0, 0.5, 1.0, 2.0]), 1.0, 1.0)
    array([2. , 1.5, 1. , 1. ])
    """
    return np.asarray(1.0 + push * np.clip(1.0 - dist / reach, 0.0, 1.0))


def _region(
    V: FloatArray,
    F: IntArray,
    kept: BoolArray,
    pairs: IntArray,
    theta: FloatArray,
    centre: int,
    from_landmarks: bool,
    counts: tuple[int, int, int, int],
) -> FaceRegion:
    """The :class:`FaceRegion` of the kept faces, its topology checked."""
    vmap = np.unique(F[kept])
    remap = np.full(V.shape[0], -1, dtype=np.int64)
    remap[vmap] = np.arange(vmap.size)
    F2 = remap[F[kept]]
    E2 = mesh_edges(F2)
    chi = vmap.size - E2.edges.shape[0] + F2.shape[0]
    be_v = np.bincount(E2.boundary.reshape(-1), minlength=vmap.size)
    if chi != 1 or E2.boundary.size == 0 or be_v.max() > 2:
        raise FaceRegionError(
            f"the face region is not a disk (Euler characteristic {chi}, "
            f"{E2.boundary.shape[0]} boundary edges): a handle or a pinch lies inside it"
        )
    cut = kept[pairs[:, 0]] != kept[pairs[:, 1]]
    crease = float(np.degrees(np.median(theta[cut]))) if cut.any() else 0.0
    core_n, bg_n, islands, fans = counts
    return FaceRegion(
        face_mask=kept,
        vertex_map=vmap,
        F=F2,
        centre=int(centre),
        from_landmarks=from_landmarks,
        core_faces=core_n,
        background_faces=bg_n,
        boundary_edges=int(E2.boundary.shape[0]),
        boundary_crease_deg=crease,
        filled_islands=islands,
        bowtie_fans=fans,
    )
