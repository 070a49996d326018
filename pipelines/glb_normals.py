"""The normals of a morph GLB: the base ``NORMAL`` and the frames' normals its NORMAL
morph targets hold (:func:`conformorph.pipelines.export_gltf.write_morph_glb`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.threads import map_in_threads
from conformorph.geometry.vertex_normals import VertexNormals, vertex_normals

_FALLBACK_NORMAL = np.array([0.0, 0.0, 1.0])
#: NORMAL targets are written only when some frame's unit normal moves by more than this
#: (a chord length: 1e-3 is 0.057°) from the base's; a planar 2D morph never needs them
NORMAL_CHANGE_TOL = 1e-3


def unit_vertex_normals(V: NDArray[np.float64], F: NDArray[np.int64]) -> NDArray[np.float64]:
    """Smooth unit vertex normals for ``NORMAL``: :func:`conformorph.geometry.vertex_normals`, never zero.

    glTF requires every ``NORMAL`` to have unit length, so a vertex whose
    incident face normals cancel (or that no face uses) gets +z instead of
    :func:`conformorph.geometry.vertex_normals`' (0, 0, 0); every other vertex keeps its
    area-weighted normal. A counter-clockwise 2D mesh at z = 0 gets +z everywhere.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, 3) int64
        Consistently oriented triangles.

    Returns
    -------
    N : (n, 3) float64
        Unit normals.
    """
    return _never_zero(vertex_normals(V, F))


def _never_zero(N: NDArray[np.float64]) -> NDArray[np.float64]:
    """``N`` (n, 3) with every zero row set to +z, in place (glTF's NORMAL is unit)."""
    N[~np.any(N != 0.0, axis=1)] = _FALLBACK_NORMAL
    return N


def changed_normals(
    fr: NDArray[np.float64], Fi: NDArray[np.int64], base_N: NDArray[np.float64]
) -> NDArray[np.float64] | None:
    """(T, n, 3) unit normals of every frame, or None when none moves by more than
    :data:`NORMAL_CHANGE_TOL` from ``base_N`` (then NORMAL targets would be zeros)."""
    normals = VertexNormals(Fi, fr.shape[1])  # one connectivity: set up once
    frame_N = np.zeros_like(fr)

    def frame(k: int) -> float:  # frame by frame: no (T, n, 3) temporaries
        frame_N[k] = _never_zero(normals(fr[k]))
        return float(np.abs(frame_N[k] - base_N).max(initial=0.0))

    moved = max(map_in_threads(frame, list(range(fr.shape[0]))), default=0.0)
    return None if moved <= NORMAL_CHANGE_TOL else frame_N
