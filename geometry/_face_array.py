"""The face array every mesh-repair step starts from, checked once in one place."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._typing import IntArray


def face_array(F: Any) -> IntArray:
    """``F`` as an (m, 3) int64 array, or ValueError naming its shape and dtype.

    Parameters
    ----------
    F : array_like, (m, 3) integer, m > 0

    Returns
    -------
    F : (m, 3) int64
        A new array (the input is never changed).
    """
    F = np.asarray(F)
    if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] == 0 or not np.issubdtype(F.dtype, np.integer):
        raise ValueError(f"F must be a non-empty (m, 3) integer array, got {F.shape} {F.dtype}")
    return F.astype(np.int64)


def faces_and_vertex_count(F: Any, n: int | None) -> tuple[IntArray, int]:
    """:func:`face_array` and the vertex count ``n`` (default ``max(F) + 1``), with every
    index checked to lie in ``0..n-1`` (ValueError otherwise)."""
    F = face_array(F)
    n = int(F.max()) + 1 if n is None else int(n)
    if F.min() < 0 or F.max() >= n:
        raise ValueError(f"F indexes vertices outside 0..{n - 1}")
    return F, n
