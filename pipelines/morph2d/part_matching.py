"""Parts of two shapes put in correspondence: a cost matrix and the Hungarian algorithm.

Both shapes are put in one normal frame (all parts together: centroid at the
origin, unit total area), so a part's place and size are read relative to its
whole shape. A pair (i, j) costs

    |c_i - c_j| + SIZE_WEIGHT · |log(a_i / a_j)| - OVERLAP_WEIGHT · IoU(i, j),

with c the centroid, a the area and IoU the parts' overlap (intersection over
union) in that frame; :func:`scipy.optimize.linear_sum_assignment` takes the
pairing of least total cost. Pairs pinned by anchors cost nothing (and every
other pair with either part costs ``PIN_COST``). With unequal counts the parts
left over have no partner: they grow out of a point or shrink into one
(:mod:`conformorph.pipelines.morph2d.part_morph`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from conformorph.geometry.assignment import min_cost_assignment
from conformorph.geometry.shape_rings import ShapeRings

#: Weight of ``|log(area ratio)|`` against the centroid distance (normal frame).
SIZE_WEIGHT = 0.5
#: Weight of the overlap (IoU in the normal frame) subtracted from the cost.
OVERLAP_WEIGHT = 0.5
#: Cost of a pair that contradicts an anchor's pinned pair.
PIN_COST = 1e6


@dataclass(frozen=True)
class PartMatching:
    """Pairs of parts of two shapes.

    Attributes
    ----------
    pairs : (p, 2) int64
        ``[source part, target part]``, by source part.
    cost : (p,) float64
    unmatched_source, unmatched_target : (u,), (v,) int64
        Parts without a partner.
    pinned : (q, 2) int64
        Pairs the anchors pinned.
    """

    pairs: NDArray[np.int64]
    cost: NDArray[np.float64]
    unmatched_source: NDArray[np.int64]
    unmatched_target: NDArray[np.int64]
    pinned: NDArray[np.int64]

    def as_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {
            "pairs": self.pairs.tolist(),
            "cost": [float(c) for c in self.cost],
            "unmatched_source": self.unmatched_source.tolist(),
            "unmatched_target": self.unmatched_target.tolist(),
            "pinned": self.pinned.tolist(),
        }


def part_polygon(shape: ShapeRings) -> shapely.Polygon:
    """A part as a shapely polygon (outer ring and holes)."""
    return shapely.Polygon(shape.outer, [h for h in shape.holes])


def _normalised(parts: Sequence[ShapeRings]) -> list[shapely.Polygon]:
    polys = [part_polygon(p) for p in parts]
    whole = shapely.union_all(polys)
    c = whole.centroid
    s = 1.0 / np.sqrt(max(whole.area, 1e-300))
    return [
        shapely.affinity.scale(shapely.affinity.translate(p, -c.x, -c.y), s, s, origin=(0, 0))
        for p in polys
    ]


def match_parts(
    source: Sequence[ShapeRings],
    target: Sequence[ShapeRings],
    pins: Sequence[tuple[int, int]] = (),
) -> PartMatching:
    """Pair the parts of two shapes by place, size and overlap.

    Parameters
    ----------
    source, target : sequence of ShapeRings
        The parts (at least one each).
    pins : sequence of (int, int)
        ``(source part, target part)`` pairs that anchors fix.

    Returns
    -------
    PartMatching

    Raises
    ------
    ValueError
        No parts, a pin out of range, or pins that pair one part twice.
    """
    if not source or not target:
        raise ValueError("both shapes need at least one part")
    pin = np.asarray(sorted(set(pins)), dtype=np.int64).reshape(-1, 2)
    if pin.size and (
        pin[:, 0].max() >= len(source) or pin[:, 1].max() >= len(target) or pin.min() < 0
    ):
        raise ValueError(f"anchor part pair out of range: {pin.tolist()}")
    if len(set(pin[:, 0].tolist())) < len(pin) or len(set(pin[:, 1].tolist())) < len(pin):
        raise ValueError(f"anchors pair one part with two others: {pin.tolist()}")
    P, Q = _normalised(source), _normalised(target)
    C = np.zeros((len(P), len(Q)))
    for i, p in enumerate(P):
        for j, q in enumerate(Q):
            d = float(np.hypot(p.centroid.x - q.centroid.x, p.centroid.y - q.centroid.y))
            size = abs(np.log(p.area / q.area))
            union = p.union(q).area
            iou = p.intersection(q).area / union if union > 0 else 0.0
            C[i, j] = d + SIZE_WEIGHT * size - OVERLAP_WEIGHT * iou
    for i, j in pin:
        C[i, :] = PIN_COST
        C[:, j] = PIN_COST
    for i, j in pin:
        C[i, j] = 0.0
    rows, cols = min_cost_assignment(C)
    pairs = np.c_[rows, cols].astype(np.int64)
    return PartMatching(
        pairs=pairs,
        cost=C[rows, cols],
        unmatched_source=np.setdiff1d(np.arange(len(P)), rows).astype(np.int64),
        unmatched_target=np.setdiff1d(np.arange(len(Q)), cols).astype(np.int64),
        pinned=pin,
    )
