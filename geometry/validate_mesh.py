"""Validation of triangle meshes before any numerics.

Each failure raises its own :class:`~conformorph.geometry.mesh_errors.MeshError` subclass
with a message that says what is wrong and where (vertex, face or loop
indices, 0-based). Checks run in a fixed order, cheapest and most basic
first, so that later checks can rely on earlier ones.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ._typing import FloatArray, IntArray
from .boundary_loop import boundary_loops
from .mesh_edges import MeshEdges, mesh_edges
from .mesh_errors import (
    BoundaryEarError,
    FaceIndexOutOfRangeError,
    MultipleComponentsError,
    NonFiniteCoordinatesError,
    NonManifoldError,
    NotDiskError,
    NotTrianglesError,
    RepeatedFaceIndexError,
    UnreferencedVertexError,
    ZeroAreaFaceError,
)
from .tolerances import ZERO_AREA_RTOL


@dataclass(frozen=True)
class MeshReport:
    """What validation found about a mesh that passed.

    Attributes
    ----------
    n_vertices, n_faces, n_edges : int
    boundary_loops : int
        Number of boundary loops.
    boundary_loop_sizes : list of int
        Vertices per loop, longest first.
    euler_characteristic : int
        χ = V − E + F (1 for a disk).
    components : int
    boundary_ears : list of int
        Boundary vertices that lie in a single triangle (only reported when
        ``allow_ears=True``).
    boundary : (k,) int64
        The longest boundary loop, oriented like the faces (empty if closed).
    edges : MeshEdges
        The edge incidence found on the way, for callers that need it next
        (e.g. :func:`conformorph.geometry.cotangent_laplacian`); not part of :meth:`to_dict`.
    """

    n_vertices: int
    n_faces: int
    n_edges: int
    boundary_loops: int
    boundary_loop_sizes: list[int]
    euler_characteristic: int
    components: int
    boundary_ears: list[int]
    boundary: IntArray = field(
        repr=False, compare=False, default_factory=lambda: np.zeros(0, np.int64)
    )
    edges: MeshEdges | None = field(repr=False, compare=False, default=None)

    def to_dict(self) -> dict[str, Any]:
        """The report as a JSON-ready dict."""
        return {
            f.name: copy.copy(getattr(self, f.name))
            for f in fields(self)
            if f.name not in ("boundary", "edges")
        }


def _preview(idx: IntArray | list[int], limit: int = 8) -> str:
    items = [int(i) for i in list(idx)[:limit]]
    more = len(idx) - len(items)
    return str(items) + (f" and {more} more" if more > 0 else "")


def as_mesh_arrays(V: Any, F: Any) -> tuple[FloatArray, IntArray]:
    """Check shapes and dtypes and return float64 / int64 copies.

    Parameters
    ----------
    V : array_like, (n, 3)
    F : array_like, (m, 3), integer

    Returns
    -------
    V : (n, 3) float64
    F : (m, 3) int64

    Raises
    ------
    NotTrianglesError
        Wrong shapes, non-integer faces, or an empty mesh.
    """
    V = np.asarray(V)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise NotTrianglesError(f"vertices must have shape (n, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3:
        raise NotTrianglesError(
            f"faces must be triangles with shape (m, 3), got {F.shape}"
            + (" (polygons with more than 3 corners)" if F.ndim == 2 and F.shape[1] > 3 else "")
        )
    if V.shape[0] == 0 or F.shape[0] == 0:
        raise NotTrianglesError(f"empty mesh: {V.shape[0]} vertices, {F.shape[0]} faces")
    if not np.issubdtype(F.dtype, np.integer):
        if np.issubdtype(F.dtype, np.floating) and np.all(np.mod(F, 1) == 0):
            F = F.astype(np.int64)
        else:
            raise NotTrianglesError(f"face indices must be integers, got dtype {F.dtype}")
    if not np.issubdtype(V.dtype, np.number):
        raise NotTrianglesError(f"vertex coordinates must be numbers, got dtype {V.dtype}")
    return V.astype(np.float64, copy=True), F.astype(np.int64, copy=True)


def triangle_areas(V: FloatArray, F: IntArray) -> FloatArray:
    """Unsigned triangle areas.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Returns
    -------
    A : (m,) float64
    """
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)


def _nonmanifold_vertices(F: IntArray, n: int, E: MeshEdges) -> IntArray:
    """Vertices whose incident faces do not form one edge-connected fan."""
    m = F.shape[0]
    corner_vertex = F.reshape(-1)  # corner c = 3 f + k
    # pair up the two half-edges of every interior edge
    he_edge = E.halfedge_edge.reshape(-1)
    order = np.argsort(he_edge, kind="stable")
    sorted_edges = he_edge[order]
    first = np.ones(sorted_edges.size, dtype=bool)
    first[1:] = sorted_edges[1:] != sorted_edges[:-1]
    starts = np.flatnonzero(first)
    pairs = starts[E.face_count[sorted_edges[starts]] == 2]
    h1, h2 = order[pairs], order[pairs + 1]  # half-edge ids: 3 f + k, edge (F[f,k], F[f,k+1])
    f1, k1 = np.divmod(h1, 3)
    f2, k2 = np.divmod(h2, 3)
    # corners at both endpoints of the shared edge
    a1 = 3 * f1 + k1
    b1 = 3 * f1 + (k1 + 1) % 3
    a2 = 3 * f2 + k2
    b2 = 3 * f2 + (k2 + 1) % 3
    # match corners by vertex: half-edge 2 runs opposite (or same, if misoriented)
    same_a = corner_vertex[a1] == corner_vertex[a2]
    u = np.concatenate([a1, b1])
    v = np.concatenate([np.where(same_a, a2, b2), np.where(same_a, b2, a2)])
    G = sp.coo_array((np.ones(u.size), (u, v)), shape=(3 * m, 3 * m))
    _, labels = connected_components(G, directed=False)
    fans = np.zeros(n, dtype=np.int64)
    uniq = np.unique(labels.astype(np.int64) * n + corner_vertex)
    np.add.at(fans, uniq % n, 1)
    return np.flatnonzero(fans > 1)


def boundary_ear_vertices(F: IntArray, E: MeshEdges | None = None) -> IntArray:
    """Boundary vertices that lie in exactly one triangle ("ears").

    Parameters
    ----------
    F : (m, 3) int64
    E : MeshEdges, optional
        ``mesh_edges(F)`` if already computed.

    Returns
    -------
    ears : (e,) int64
        Sorted vertex indices.
    """
    valence = np.bincount(F.reshape(-1))
    E = mesh_edges(F) if E is None else E
    bverts = np.unique(E.boundary.reshape(-1))
    return bverts[valence[bverts] == 1].astype(np.int64)


def validate_mesh_elements(V: Any, F: Any) -> tuple[FloatArray, IntArray]:
    """The cheap element-wise checks of :func:`validate_mesh`, in its order.

    Shapes and dtypes, finite coordinates, face indices in range and not
    repeated within a face, no zero-area triangle, no unreferenced vertex.
    Run these before a repair (:func:`geometry.remove_boundary_ears`,
    :func:`geometry.fill_holes`), which index with the faces and would
    otherwise fail obscurely or silently drop unreferenced vertices.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles (0-based).

    Returns
    -------
    V : (n, 3) float64
        A checked copy.
    F : (m, 3) int64
        A checked copy.

    Raises
    ------
    NotTrianglesError, NonFiniteCoordinatesError, FaceIndexOutOfRangeError,
    RepeatedFaceIndexError, ZeroAreaFaceError, UnreferencedVertexError
        In this order of checking; each message says where.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> validate_mesh_elements(V, [[0, 1, 7]])
    Traceback (most recent call last):
    ...
    conformorph.geometry.mesh_errors.FaceIndexOutOfRangeError: 1 faces index vertices outside 0..2: face 0 is [0, 1, 7] (faces [0])
    """
    V, F = as_mesh_arrays(V, F)
    n = V.shape[0]
    bad = np.flatnonzero(~np.all(np.isfinite(V), axis=1))
    if bad.size:
        raise NonFiniteCoordinatesError(
            f"{bad.size} vertices have NaN or infinite coordinates: vertices {_preview(bad)}"
        )
    out = np.flatnonzero(np.any((F < 0) | (F >= n), axis=1))
    if out.size:
        f = int(out[0])
        raise FaceIndexOutOfRangeError(
            f"{out.size} faces index vertices outside 0..{n - 1}: face {f} is {F[f].tolist()}"
            f" (faces {_preview(out)})"
        )
    rep = np.flatnonzero((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2]))
    if rep.size:
        f = int(rep[0])
        raise RepeatedFaceIndexError(
            f"{rep.size} faces repeat a vertex: face {f} is {F[f].tolist()} (faces {_preview(rep)})"
        )
    areas = triangle_areas(V, F)
    tiny = np.flatnonzero(areas <= ZERO_AREA_RTOL * max(float(areas.mean()), 1e-300))
    if tiny.size:
        raise ZeroAreaFaceError(f"{tiny.size} triangles have zero area: faces {_preview(tiny)}")
    unref = np.flatnonzero(np.bincount(F.reshape(-1), minlength=n) == 0)
    if unref.size:
        raise UnreferencedVertexError(
            f"{unref.size} vertices are used by no face: vertices {_preview(unref)}"
        )
    return V, F


def validate_mesh(
    V: Any, F: Any, *, require_disk: bool = True, allow_ears: bool = False
) -> MeshReport:
    """Validate a triangle mesh for the conformal pipeline.

    Parameters
    ----------
    V : (n, 3) array_like
        Vertex positions.
    F : (m, 3) array_like of int
        Triangles (0-based).
    require_disk : bool, default True
        Also require disk topology: one component, one boundary loop, χ = 1.
    allow_ears : bool, default False
        Accept boundary vertices that lie in a single triangle (they give
        100–150° angle distortion in every disk map; see
        :func:`geometry.remove_boundary_ears`).

    Returns
    -------
    MeshReport

    Raises
    ------
    NotTrianglesError, NonFiniteCoordinatesError, FaceIndexOutOfRangeError,
    RepeatedFaceIndexError, ZeroAreaFaceError, UnreferencedVertexError, NonManifoldError,
    MultipleComponentsError, NotDiskError, BoundaryEarError
        In this order of checking; each message says where.
    """
    V, F = validate_mesh_elements(V, F)
    n, m = V.shape[0], F.shape[0]
    f_v = np.bincount(F.reshape(-1), minlength=n)  # faces at each vertex
    E = mesh_edges(F)
    nm = np.flatnonzero(E.face_count > 2)
    if nm.size:
        raise NonManifoldError(
            f"{nm.size} edges are shared by more than two faces: edges "
            f"{[E.edges[i].tolist() for i in nm[:5]]}"
        )
    # A vertex with f faces and e edges around it, k_open open fans and
    # k_closed closed ones has e - f = k_open and 2 k_open boundary edges.
    # Counts therefore reveal several open fans; several closed fans (a pinch)
    # lower χ below 1, so for disks the O(m) count test is complete and the
    # corner-graph test (which names the vertices) runs only when needed.
    e_v = np.bincount(E.edges.reshape(-1), minlength=n)
    be_v = np.bincount(E.boundary.reshape(-1), minlength=n)
    suspicious = bool(np.any(e_v - f_v > 1) or np.any(be_v > 2)) or not require_disk
    chi = n - E.edges.shape[0] + F.shape[0]
    nmv = _nonmanifold_vertices(F, n, E) if suspicious or chi != 1 else np.zeros(0, np.int64)
    if nmv.size:
        raise NonManifoldError(
            f"{nmv.size} vertices are non-manifold (their faces form several fans): "
            f"vertices {_preview(nmv)}"
        )
    adj = sp.coo_array((np.ones(E.edges.shape[0]), (E.edges[:, 0], E.edges[:, 1])), shape=(n, n))
    ncomp, labels = connected_components(adj, directed=False)
    if ncomp > 1:
        sizes = np.bincount(labels)
        raise MultipleComponentsError(
            f"the mesh has {ncomp} connected components (vertex counts "
            f"{_preview(np.sort(sizes)[::-1].tolist())}); keep the largest or split it"
        )
    loops = boundary_loops(F, E)
    if require_disk:
        if len(loops) != 1 or chi != 1:
            msg = (
                f"not a disk: {len(loops)} boundary loops and Euler characteristic {chi} "
                "(a disk has 1 loop and χ = 1)"
            )
            if len(loops) > 1:
                holes = ", ".join(
                    f"loop {i} ({len(lp)} vertices, starting at vertex {int(lp[0])})"
                    for i, lp in enumerate(loops[1:], start=1)
                )
                msg += f"; holes: {holes}; fill them with geometry.fill_holes (CLI: --fill-holes)"
            elif not loops:
                msg += "; the surface is closed: cut it open first"
            raise NotDiskError(msg)
    ears = boundary_ear_vertices(F, E)
    if ears.size and not allow_ears and m > 1:  # a lone triangle is all ears by definition
        raise BoundaryEarError(
            f"{ears.size} boundary vertices lie in a single triangle (ears): vertices "
            f"{_preview(ears)}; remove them with geometry.remove_boundary_ears "
            "(CLI: --remove-ears)"
        )
    return MeshReport(
        n_vertices=n,
        n_faces=m,
        n_edges=int(E.edges.shape[0]),
        boundary_loops=len(loops),
        boundary_loop_sizes=[len(lp) for lp in loops],
        euler_characteristic=int(chi),
        components=int(ncomp),
        boundary_ears=ears.tolist(),
        boundary=loops[0] if loops else np.zeros(0, np.int64),
        edges=E,
    )
