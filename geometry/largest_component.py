"""The largest connected component of a triangle mesh, and the sizes of the others."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ._face_array import face_array
from ._typing import BoolArray, IntArray


@dataclass(frozen=True)
class ComponentSelection:
    """Which faces form the largest component.

    Attributes
    ----------
    face_mask : (m,) bool
        True for the faces of the largest component (by vertex count; the
        first in face order among equals).
    dropped_vertex_counts : list of int
        Vertex counts of the other components, largest first.
    dropped_face_counts : list of int
        Their face counts, in the same order.
    """

    face_mask: BoolArray
    dropped_vertex_counts: list[int]
    dropped_face_counts: list[int]


def largest_component(F: IntArray) -> ComponentSelection:
    """The faces of the largest vertex-connected component of ``F``.

    Parameters
    ----------
    F : (m, 3) int64
        Triangles (vertex indices ≥ 0). Vertices used by no face are not
        counted in any component.

    Returns
    -------
    ComponentSelection

    Raises
    ------
    ValueError
        ``F`` is not a non-empty (m, 3) array of non-negative indices.

    Notes
    -----
    Two faces are in one component when a chain of faces, each sharing a
    vertex with the next, joins them: the same components as
    :func:`conformorph.geometry.validate_mesh` counts on the edge graph.

    Examples
    --------
    >>> F = np.array([[0, 1, 2], [1, 3, 2], [4, 5, 6]])
    >>> s = largest_component(F)
    >>> s.face_mask.tolist(), s.dropped_vertex_counts, s.dropped_face_counts
    ([True, True, False], [3], [1])
    """
    F = face_array(F)
    if F.min() < 0:
        raise ValueError("F has negative vertex indices")
    n = int(F.max()) + 1
    u = np.concatenate([F[:, 0], F[:, 1]])
    v = np.concatenate([F[:, 1], F[:, 2]])
    G = sp.coo_array((np.ones(u.size), (u, v)), shape=(n, n))
    _, labels = connected_components(G, directed=False)
    used = np.zeros(n, dtype=bool)
    used[F.reshape(-1)] = True
    vcount = np.bincount(labels[used], minlength=int(labels.max()) + 1)
    face_label = labels[F[:, 0]]
    fcount = np.bincount(face_label, minlength=vcount.size)
    # the largest by vertices; among equals the one whose first face comes first
    first_face = np.full(vcount.size, F.shape[0], dtype=np.int64)
    np.minimum.at(first_face, face_label, np.arange(F.shape[0]))
    order = np.lexsort((first_face, -vcount))
    best = int(order[0])
    others = [int(c) for c in order[1:] if vcount[c] > 0]
    return ComponentSelection(
        face_mask=face_label == best,
        dropped_vertex_counts=[int(vcount[c]) for c in others],
        dropped_face_counts=[int(fcount[c]) for c in others],
    )
