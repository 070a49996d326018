"""MediaPipe's 478 FaceMesh points → the Multi-PIE 68 landmarks, by a committed table.

Each of the 68 points is an affine combination (weights summing to 1) of a few
FaceMesh points in image space. The table ``multipie68_table.json`` beside this
module is fitted on annotated ICT-FaceKit meshes by
``scripts/calibrate_landmarks.py``, which records its method and held-out
errors in the file.

Multi-PIE order (0-based): jaw 0–16, eyebrows 17–26, nose 27–35, eyes 36–47,
outer lips 48–59, inner lips 60–67; the "inner 51" are 17–67.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

TABLE_PATH = Path(__file__).with_name("multipie68_table.json")

#: Multi-PIE groups, 0-based
JAW = tuple(range(0, 17))
INNER_51 = tuple(range(17, 68))
INNER_LIPS = tuple(range(60, 68))
N_MULTIPIE = 68
N_FACEMESH = 478


@dataclass(frozen=True)
class Multipie68Table:
    """The 478 → 68 mapping.

    Attributes
    ----------
    index : (68, k) int64
        FaceMesh point ids combined for each landmark.
    weight : (68, k) float64
        Their weights; each row sums to 1.
    meta : dict
        The file's other keys (method, calibration faces, held-out errors).
    """

    index: NDArray[np.int64]
    weight: NDArray[np.float64]
    meta: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        """The JSON document (``index`` and ``weight`` lists, then ``meta``'s keys)."""
        return {
            **self.meta,
            "index": self.index.tolist(),
            "weight": [[round(float(w), 6) for w in row] for row in self.weight],
        }


def table_from_json(data: dict[str, Any]) -> Multipie68Table:
    """Check and build a table from its JSON document.

    Raises
    ------
    ValueError
        Not 68 rows, ids out of 0..477, or weights not summing to 1.
    """
    index = np.asarray(data["index"], dtype=np.int64)
    weight = np.asarray(data["weight"], dtype=np.float64)
    if index.ndim != 2 or index.shape[0] != N_MULTIPIE or weight.shape != index.shape:
        raise ValueError(f"multipie68 table: expected (68, k) index and weight, got {index.shape}")
    if index.min() < 0 or index.max() >= N_FACEMESH:
        raise ValueError("multipie68 table: FaceMesh ids must be in 0..477")
    if not np.allclose(weight.sum(axis=1), 1.0, atol=1e-4):
        raise ValueError("multipie68 table: each row of weights must sum to 1")
    meta = {k: v for k, v in data.items() if k not in ("index", "weight")}
    return Multipie68Table(index, weight / weight.sum(axis=1, keepdims=True), meta)


@lru_cache(maxsize=1)
def load_multipie68_table(path: str | None = None) -> Multipie68Table:
    """The committed table (or the one at ``path``)."""
    return table_from_json(json.loads(Path(path or TABLE_PATH).read_text()))


def multipie68_from_facemesh(
    points: NDArray[np.float64], table: Multipie68Table
) -> NDArray[np.float64]:
    """The 68 Multi-PIE positions as combinations of FaceMesh points.

    Parameters
    ----------
    points : (478, d) float64
        FaceMesh points (pixels, d = 2).
    table : Multipie68Table

    Returns
    -------
    (68, d) float64
        ``sum_j weight[l, j] * points[index[l, j]]``.
    """
    return np.einsum("lk,lkd->ld", table.weight, np.asarray(points)[table.index])
