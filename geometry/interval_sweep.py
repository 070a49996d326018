"""Pairs of intervals that meet, by one sort and a sweep: the broad phase of the ring
checks of :mod:`conformorph.geometry.shape_rings` and
:mod:`conformorph.geometry.touching_rings`."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from ._typing import FloatArray, IntArray

#: Candidate segment pairs (or point × edge entries) handled per vectorised block:
#: bounds the memory of the intersection and containment tests.
SWEEP_BLOCK = 1 << 18


def x_overlap_pairs(
    lo_a: FloatArray, hi_a: FloatArray, lo_b: FloatArray, hi_b: FloatArray
) -> Iterator[tuple[IntArray, IntArray]]:
    """Index pairs (i, j) whose closed intervals [lo_a[i], hi_a[i]] and [lo_b[j], hi_b[j]] meet.

    Two intervals meet exactly when one starts inside the other: b's start in
    [lo_a[i], hi_a[i]], or a's start in (lo_b[j], hi_b[j]] (strict on the left
    so that no pair is listed twice). Each case is a contiguous run of the
    starts sorted once (a sort-and-sweep), so the pairs are produced in
    blocks of about ``SWEEP_BLOCK`` (yielded one at a time) without forming a
    k × k matrix.
    """
    for lo_p, hi_p, lo_q, left, swap in (
        (lo_a, hi_a, lo_b, "left", False),
        (lo_b, hi_b, lo_a, "right", True),
    ):
        order = np.argsort(lo_q, kind="stable")
        start = np.searchsorted(lo_q[order], lo_p, side=left)  # type: ignore[call-overload]
        stop = np.searchsorted(lo_q[order], hi_p, side="right")
        count = np.maximum(stop - start, 0)
        ends = np.cumsum(count)
        r0 = 0
        while r0 < count.shape[0]:
            base = int(ends[r0 - 1]) if r0 else 0
            r1 = max(int(np.searchsorted(ends, base + SWEEP_BLOCK, side="right")), r0 + 1)
            c = count[r0:r1]
            rows = np.repeat(np.arange(r0, r1), c)
            first = np.cumsum(c) - c
            cols = order[
                np.repeat(start[r0:r1], c) + np.arange(rows.shape[0]) - np.repeat(first, c)
            ]
            if rows.shape[0]:
                yield (cols, rows) if swap else (rows, cols)
            r0 = r1
