"""Rings of a 2D shape that touch, one another or themselves, parted by a hair.

A hole that touches the outline or another hole at a point, or an outline pinched onto
itself, is common in icons and valid for shapely, but no mesh with separate boundary
loops can carry it. :func:`part_touching_rings` moves each touching tip a little into its
own narrower angle; :func:`conformorph.geometry.shape_rings.validate_rings` calls it and
reports what moved.
"""

from __future__ import annotations

import numpy as np

from ._typing import FloatArray, IntArray
from .interval_sweep import x_overlap_pairs
from .tolerances import RING_PART_GAP, RING_TIP_MAX_ANGLE, RING_TOUCH_RTOL


def _touching_vertices(a: FloatArray, b: FloatArray, same: bool, tol: float) -> IntArray:
    """Vertices of ring ``a`` within ``tol`` of an edge of ring ``b`` (with ``same``, of an
    edge of ``a`` not incident to the vertex), found by the sweep of :func:`conformorph.geometry.shape_rings._crossings`."""
    Pb, Qb = b, np.roll(b, -1, axis=0)
    lo_b, hi_b = np.minimum(Pb, Qb) - tol, np.maximum(Pb, Qb) + tol
    k = a.shape[0]
    hits: list[IntArray] = []
    for i, j in x_overlap_pairs(a[:, 0], a[:, 0], lo_b[:, 0], hi_b[:, 0]):
        keep = (lo_b[j, 1] <= a[i, 1]) & (a[i, 1] <= hi_b[j, 1])
        if same:
            keep &= (j != i) & ((j + 1) % k != i)
        i, j = i[keep], j[keep]
        d = Qb[j] - Pb[j]
        t = np.clip(np.einsum("ij,ij->i", a[i] - Pb[j], d) / np.einsum("ij,ij->i", d, d), 0, 1)
        gap = np.linalg.norm(Pb[j] + t[:, None] * d - a[i], axis=1)
        hits.append(i[gap <= tol])
    return np.unique(np.concatenate(hits)) if hits else np.zeros(0, dtype=np.int64)


def _parting_steps(a: FloatArray, near: IntArray) -> FloatArray:
    """(len(near), 2) unit steps that part the vertices ``near`` of ring ``a`` (inside on
    its left) from what they touch: along the bisector of the vertex's edges, into the
    narrower of its two angles.

    A touching vertex is the tip of a wedge that meets another stretch of boundary:
    a hole's corner on the outline (the hole's angle there is the narrower one), the
    outline's notch on a hole (the outside's), two lobes of an outline pinched
    together (each lobe's inside), two lobes of a hole (each lobe's hole). Into the
    tip's own wedge is away from the other stretch in every one of these cases: a
    convex corner (a left turn) steps into the inside, a reflex one out of it. A
    vertex whose narrower angle is over ``RING_TIP_MAX_ANGLE`` degrees is a stretch
    that a tip touches, not a tip: its step is zero (the tip's step parts them).
    """
    k = a.shape[0]
    e_in, e_out = a[near] - a[near - 1], a[(near + 1) % k] - a[near]
    right = sum(
        np.stack([e[:, 1], -e[:, 0]], axis=1) / np.linalg.norm(e, axis=1)[:, None]
        for e in (e_in, e_out)
    )
    right = right / np.maximum(np.linalg.norm(right, axis=1), 1e-300)[:, None]
    cross = e_in[:, 0] * e_out[:, 1] - e_in[:, 1] * e_out[:, 0]
    # the narrower angle at the vertex: pi less the turn; a vertex nearly straight is the
    # other stretch's, not a tip (its narrower side is a hair's bend): it stays
    turn = np.abs(np.arctan2(cross, np.einsum("ij,ij->i", e_in, e_out)))
    tip = np.pi - turn < np.radians(RING_TIP_MAX_ANGLE)
    step = np.where((cross > 0)[:, None], -right, right)
    return np.asarray(np.where(tip[:, None], step, 0.0))


def part_touching_rings(rings: list[FloatArray]) -> list[str]:
    """Move apart (replacing them in ``rings``) rings that touch, one another or
    themselves (``RING_TOUCH_RTOL``): each touching vertex steps ``RING_PART_GAP`` of
    the extent (at most a quarter of its shorter edge) along :func:`_parting_steps`.

    A hole that touches the outline or another hole at a point, or an outline pinched
    onto itself (common in icons, and valid for shapely), leaves a region whose
    boundaries meet, which no mesh with separate boundary loops can carry; and two
    vertices a rounding apart become one when the part is scaled (a part that grows
    or shrinks). Returns what was done, for ``ShapeRings.fixes``.
    """
    extent = float(np.max(rings[0].max(axis=0) - rings[0].min(axis=0)))
    tol = RING_TOUCH_RTOL * extent
    fixes = []
    lo = np.array([r.min(axis=0) for r in rings]) - tol
    hi = np.array([r.max(axis=0) for r in rings]) + tol
    for i, a in enumerate(rings):
        for j, b in enumerate(rings):
            if np.any(lo[i] > hi[j]) or np.any(lo[j] > hi[i]):
                continue  # boxes apart: nothing touches (cheap for shapes of many holes)
            near = _touching_vertices(a, b, i == j, tol)
            if len(near) == 0:
                continue
            edges = np.vstack([a[near] - a[near - 1], a[(near + 1) % len(a)] - a[near]])
            step = min(RING_PART_GAP * extent, 0.25 * float(np.linalg.norm(edges, axis=1).min()))
            move = _parting_steps(a, near)
            moved = int(np.count_nonzero(np.any(move != 0.0, axis=1)))
            if moved == 0:
                continue
            a = rings[i] = a.copy()  # the caller's array may be this ring
            a[near] += step * move
            what = "outer ring" if i == 0 else f"hole {i}"
            other = "itself" if i == j else "the outer ring" if j == 0 else f"hole {j}"
            fixes.append(f"{what}: moved {moved} point(s) touching {other} by {step:.3g}")
    return fixes
