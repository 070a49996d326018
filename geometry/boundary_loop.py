"""Boundary loops of a triangle mesh, oriented like its faces."""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .mesh_edges import MeshEdges, mesh_edges
from .mesh_errors import NonManifoldError, NotDiskError


def boundary_loops(F: IntArray, E: MeshEdges | None = None) -> list[IntArray]:
    """All boundary loops, each oriented like the faces (mesh interior on the left).

    Parameters
    ----------
    F : (m, 3) int64
        Triangles of an edge-manifold mesh.
    E : MeshEdges, optional
        ``mesh_edges(F)`` if already computed.

    Returns
    -------
    loops : list of (k_i,) int64
        Vertex indices of each loop, longest first. A boundary half-edge
        (i, j) of a face is followed by the boundary half-edge leaving j.

    Raises
    ------
    NonManifoldError
        If a boundary vertex has more than one outgoing boundary half-edge
        (a vertex where two boundary loops touch).
    """
    E = mesh_edges(F) if E is None else E
    he = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    bhe = he[E.face_count[E.halfedge_edge.reshape(-1)] == 1]
    if bhe.size == 0:
        return []
    starts, nxt_count = np.unique(bhe[:, 0], return_counts=True)
    if np.any(nxt_count > 1):
        bad = starts[nxt_count > 1][:5].tolist()
        raise NonManifoldError(
            f"boundary vertices {bad} each start more than one boundary edge "
            "(two boundary loops touch there)"
        )
    nxt = dict(zip(bhe[:, 0].tolist(), bhe[:, 1].tolist(), strict=True))
    loops: list[IntArray] = []
    unvisited = set(nxt)
    while unvisited:
        v0 = min(unvisited)
        loop = [v0]
        unvisited.discard(v0)
        v = nxt[v0]
        while v != v0:
            if v not in unvisited:
                raise NonManifoldError(f"boundary walk from vertex {v0} does not close")
            loop.append(v)
            unvisited.discard(v)
            v = nxt[v]
        loops.append(np.asarray(loop, dtype=np.int64))
    loops.sort(key=len, reverse=True)
    return loops


def boundary_loop(F: IntArray, V: FloatArray | None = None) -> IntArray:
    """The boundary loop of a disk-topology mesh.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles.
    V : (n, 3) float64, optional
        Vertex positions. With several loops and ``V`` given, the loop of
        greatest 3D length is the outer one; without ``V`` a mesh with several
        loops is an error (libigl's ``boundary_loop`` silently picks one).

    Returns
    -------
    b : (k,) int64
        Boundary vertices in order, the mesh interior on the left.

    Raises
    ------
    NotDiskError
        If there is no boundary, or several loops and no ``V``.
    """
    loops = boundary_loops(F)
    if not loops:
        raise NotDiskError("the mesh has no boundary (it is closed), so it is not a disk")
    if len(loops) == 1:
        return loops[0]
    if V is None:
        raise NotDiskError(
            f"the mesh has {len(loops)} boundary loops (sizes {[len(x) for x in loops]}); "
            "pass V to choose the longest as the outer loop"
        )
    lengths = [float(np.linalg.norm(V[lp] - V[np.roll(lp, -1)], axis=1).sum()) for lp in loops]
    return loops[int(np.argmax(lengths))]
