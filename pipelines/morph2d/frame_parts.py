"""The frames of a 2D morph as parts and rings: the structure every writer reads.

A shape is a set of parts (polygons with holes). The morph's mesh holds one
connected component per part, with the same triangles in every frame, so each
frame's outlines follow from the mesh: a component's boundary loops, the one
enclosing the largest area its outer ring, the others its holes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components

from conformorph.geometry.boundary_loop import boundary_loops


@dataclass(frozen=True)
class FrameParts:
    """Every frame's parts, each a list of rings.

    Attributes
    ----------
    rings : list of list of list of (k_r, 2) float64
        ``rings[f][p]`` is part p at frame f: its outer ring (counter-clockwise,
        y up) then its holes (clockwise); every frame has the same parts, rings
        and point counts, in the same order (parts by decreasing area in the
        first frame).
    times : (T,) float64
        The morph parameter of each frame.
    loops : list of list of (k_r,) int64
        The mesh vertices of each ring (same layout as one frame of ``rings``).
    """

    rings: list[list[list[NDArray[np.float64]]]]
    times: NDArray[np.float64]
    loops: list[list[NDArray[np.int64]]]

    @property
    def part_count(self) -> int:
        """Number of parts."""
        return len(self.loops)

    def flat(self, frame: int) -> list[NDArray[np.float64]]:
        """All rings of one frame, part after part (a single path with evenodd fill)."""
        return [r for part in self.rings[frame] for r in part]


def _area(P: NDArray[np.float64]) -> float:
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def frame_parts(
    frames: NDArray[np.float64], F: NDArray[np.int64], times: NDArray[np.float64]
) -> FrameParts:
    """Group the mesh's boundary loops by connected component: one part per component.

    Parameters
    ----------
    frames : (T, n, 2) float64
    F : (m, 3) int64
        Counter-clockwise triangles shared by every frame.
    times : (T,) float64

    Returns
    -------
    FrameParts
    """
    n = frames.shape[1]
    rows = np.r_[F[:, 0], F[:, 1], F[:, 2]]
    cols = np.r_[F[:, 1], F[:, 2], F[:, 0]]
    graph = coo_array((np.ones(rows.shape[0]), (rows, cols)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    X0 = frames[0]
    groups: dict[int, list[NDArray[np.int64]]] = {}
    for loop in boundary_loops(F):
        groups.setdefault(int(label[loop[0]]), []).append(np.asarray(loop, dtype=np.int64))
    parts = []
    for loops in groups.values():
        outer = max(range(len(loops)), key=lambda i: abs(_area(X0[loops[i]])))
        parts.append([loops[outer]] + [lp for i, lp in enumerate(loops) if i != outer])
    parts.sort(key=lambda lps: -abs(_area(X0[lps[0]])))
    rings = [[[X[lp] for lp in lps] for lps in parts] for X in frames]
    return FrameParts(rings, np.asarray(times, dtype=np.float64), parts)
