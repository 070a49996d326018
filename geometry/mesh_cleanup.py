"""Element clean-up of a raw mesh: degenerate and duplicate faces, unreferenced vertices."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._typing import FloatArray, IntArray
from .tolerances import ZERO_AREA_RTOL
from .validate_mesh import as_mesh_arrays, triangle_areas


@dataclass(frozen=True)
class MeshCleanup:
    """A mesh without degenerate or duplicate faces and without unreferenced vertices.

    Attributes
    ----------
    V : (n2, 3) float64
        The referenced vertices, in their input order.
    F : (m2, 3) int64
        The kept faces, in their input order, re-indexed.
    kept : (n2,) int64
        ``kept[i]`` is the input row of output vertex ``i`` (increasing).
    degenerate_faces : int
        Faces dropped for repeating a vertex or having zero area
        (:data:`conformorph.geometry.tolerances.ZERO_AREA_RTOL` of the mean area).
    duplicate_faces : int
        Faces dropped for using the same three vertices as an earlier face
        (in either orientation).
    unreferenced_vertices : int
        Vertices dropped for being used by no kept face.
    """

    V: FloatArray
    F: IntArray
    kept: IntArray
    degenerate_faces: int
    duplicate_faces: int
    unreferenced_vertices: int


def clean_mesh_elements(V: object, F: object) -> MeshCleanup:
    """Drop degenerate faces, duplicate faces and unreferenced vertices, keeping orders.

    Parameters
    ----------
    V : (n, 3) array_like of float
    F : (m, 3) array_like of int

    Returns
    -------
    MeshCleanup
        The clean mesh and what was dropped. With nothing to drop, ``V`` and
        ``F`` equal the input and ``kept`` is ``arange(n)``.

    Raises
    ------
    MeshError
        Not triangles (:class:`~conformorph.geometry.mesh_errors.NotTrianglesError`),
        face indices out of range
        (:class:`~conformorph.geometry.mesh_errors.FaceIndexOutOfRangeError`), NaN or
        infinite coordinates (:class:`~conformorph.geometry.mesh_errors.NonFiniteCoordinatesError`):
        corrupt data, not repaired; or no face left after the clean-up.

    Notes
    -----
    A face is degenerate when two of its indices are equal or its area is at
    most ``ZERO_AREA_RTOL`` times the mean area of the faces with three
    distinct indices, the same test as :func:`geometry.validate_mesh_elements`,
    so a cleaned mesh passes it.

    Examples
    --------
    >>> V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]])
    >>> F = np.array([[0, 1, 2], [2, 1, 0], [0, 0, 1]])
    >>> c = clean_mesh_elements(V, F)
    >>> c.F.tolist(), c.kept.tolist(), c.duplicate_faces, c.degenerate_faces
    ([[0, 1, 2]], [0, 1, 2], 1, 1)
    """
    from .mesh_errors import FaceIndexOutOfRangeError, MeshError, NonFiniteCoordinatesError

    V, F = as_mesh_arrays(V, F)
    n = V.shape[0]
    out = np.flatnonzero(np.any((F < 0) | (F >= n), axis=1))
    if out.size:
        f = int(out[0])
        raise FaceIndexOutOfRangeError(
            f"{out.size} faces index vertices outside 0..{n - 1}: face {f} is {F[f].tolist()}"
        )
    finite = np.all(np.isfinite(V), axis=1)
    if not finite.all():  # corrupt data, not a scan artefact: refused as validation does
        bad = np.flatnonzero(~finite)
        raise NonFiniteCoordinatesError(
            f"{bad.size} vertices have NaN or infinite coordinates: vertices {bad[:8].tolist()}"
        )
    distinct = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])
    distinct &= finite[F].all(axis=1)
    areas = triangle_areas(np.where(finite[:, None], V, 0.0), F)
    mean_area = float(areas[distinct].mean()) if distinct.any() else 0.0
    good = distinct & (areas > ZERO_AREA_RTOL * max(mean_area, 1e-300))
    G = F[good]
    S = np.sort(G, axis=1)
    if n <= 1 << 21:  # the sorted triple as one 63-bit key: one stable sort, not a lexsort
        key = (S[:, 0] << 42) | (S[:, 1] << 21) | S[:, 2]
        order = np.argsort(key, kind="stable")
        repeat = np.zeros(S.shape[0], dtype=bool)
        repeat[1:] = key[order[1:]] == key[order[:-1]]
    else:
        order = np.lexsort((np.arange(S.shape[0]), S[:, 2], S[:, 1], S[:, 0]))  # stable by row
        Ss = S[order]
        repeat = np.zeros(Ss.shape[0], dtype=bool)
        repeat[1:] = np.all(Ss[1:] == Ss[:-1], axis=1)
    unique = np.ones(G.shape[0], dtype=bool)
    unique[order[repeat]] = False  # every later copy of a vertex triple
    G = G[unique]
    if G.shape[0] == 0:
        raise MeshError("no face is left once degenerate and duplicate faces are dropped")
    used = np.zeros(n, dtype=bool)
    used[G.ravel()] = True
    kept = np.flatnonzero(used)
    remap = np.full(n, -1, dtype=np.int64)
    remap[kept] = np.arange(kept.size)
    return MeshCleanup(
        V=V[kept],
        F=remap[G],
        kept=kept.astype(np.int64),
        degenerate_faces=int((~good).sum()),
        duplicate_faces=int((~unique).sum()),
        unreferenced_vertices=int(n - kept.size),
    )
