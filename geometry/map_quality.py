"""Quality measures of a disk parameterisation, shipped beside the map."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._typing import FloatArray, IntArray
from .angle_distortion import angle_distortion
from .beltrami_coefficient import beltrami_coefficient
from .flipped_triangles import flipped_triangles

#: default bin edges of the angle-distortion histogram, degrees (1° bins)
ANGLE_BIN_EDGES: FloatArray = np.arange(0.0, 181.0, 1.0)
#: default bin edges of the |μ| histogram (0.02 wide up to 1; |μ| ≥ 1 is a flip)
BELTRAMI_BIN_EDGES: FloatArray = np.linspace(0.0, 1.0, 51)


@dataclass(frozen=True)
class Histogram:
    """Counts of values in bins ``[edges[i], edges[i+1])`` (the last bin closed).

    Attributes
    ----------
    edges : (k + 1,) float64
    counts : (k,) int64
    below, above : int
        Values left of the first edge and right of the last one (and NaN
        values, counted in ``above``).
    """

    edges: FloatArray
    counts: IntArray
    below: int
    above: int

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (lists of numbers)."""
        return {
            "edges": [round(float(x), 12) for x in self.edges],
            "counts": [int(x) for x in self.counts],
            "below": self.below,
            "above": self.above,
        }


def histogram(values: FloatArray, edges: FloatArray) -> Histogram:
    """Histogram of ``values`` over increasing ``edges``, with out-of-range counts.

    Parameters
    ----------
    values : (p,) float64
    edges : (k + 1,) float64, strictly increasing, k ≥ 1

    Returns
    -------
    Histogram

    Examples
    --------
    >>> h = histogram(np.array([0.5, 1.0, 2.0, 7.0]), np.array([0.0, 1.0, 2.0]))
    >>> h.counts.tolist(), h.above
    ([1, 2], 1)
    """
    values = np.asarray(values, dtype=np.float64).reshape(-1)
    edges = np.asarray(edges, dtype=np.float64)
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError("edges must be a strictly increasing 1D array of at least 2 values")
    finite = np.isfinite(values)
    v = values[finite]
    counts, _ = np.histogram(v, bins=edges)
    below = int((v < edges[0]).sum())
    above = int((v > edges[-1]).sum()) + int((~finite).sum())
    return Histogram(edges=edges.copy(), counts=counts.astype(np.int64), below=below, above=above)


@dataclass(frozen=True)
class MapQuality:
    """Quality of a disk map ``uv`` of a surface ``(V, F)``.

    Attributes
    ----------
    n_vertices, n_faces : int
    angle_distortion_mean, angle_distortion_median, angle_distortion_max : float
        Over all triangle corners, degrees (:func:`conformorph.geometry.angle_distortion`).
    angle_histogram : Histogram
        Of the per-corner angle distortion, degrees.
    beltrami_mean, beltrami_median, beltrami_max : float
        Of the per-triangle ``|μ|`` (:func:`conformorph.geometry.beltrami_coefficient`).
    beltrami_histogram : Histogram
    flipped : int
        Triangles with non-positive signed area in the plane.
    boundary_circle_error : float
        ``max | |uv_b| − 1 |`` over the boundary vertices (NaN without ``b``).
    boundary_isoperimetric_ratio : float
        ``4π A / P²`` of the boundary polygon: 1 for a circle, smaller for
        any other shape (NaN without ``b``).
    """

    n_vertices: int
    n_faces: int
    angle_distortion_mean: float
    angle_distortion_median: float
    angle_distortion_max: float
    angle_histogram: Histogram
    beltrami_mean: float
    beltrami_median: float
    beltrami_max: float
    beltrami_histogram: Histogram
    flipped: int
    boundary_circle_error: float
    boundary_isoperimetric_ratio: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (histograms as nested dicts, NaN as None)."""
        out: dict[str, Any] = {}
        for k, v in self.__dict__.items():
            if isinstance(v, Histogram):
                out[k] = v.to_dict()
            elif isinstance(v, float) and not np.isfinite(v):
                out[k] = None
            else:
                out[k] = v
        return out


def boundary_isoperimetric_ratio(uv: FloatArray, b: IntArray) -> float:
    """``4π A / P²`` of the planar polygon ``uv[b]`` (1 for a circle).

    Parameters
    ----------
    uv : (n, 2) float64
    b : (k,) int64
        Polygon vertices in order.

    Returns
    -------
    float
    """
    p = uv[b]
    q = np.roll(p, -1, axis=0)
    area = 0.5 * abs(float((p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]).sum()))
    perim = float(np.linalg.norm(q - p, axis=1).sum())
    return 4.0 * np.pi * area / perim**2 if perim > 0 else float("nan")


def map_quality(
    V: FloatArray,
    F: IntArray,
    uv: FloatArray,
    b: IntArray | None = None,
    *,
    angle_bin_edges: FloatArray = ANGLE_BIN_EDGES,
    beltrami_bin_edges: FloatArray = BELTRAMI_BIN_EDGES,
) -> MapQuality:
    """Angle distortion, Beltrami coefficient, flips and boundary circularity of a map.

    Parameters
    ----------
    V : (n, 3) float64
        Surface. Not modified.
    F : (m, 3) int64
        Triangles.
    uv : (n, 2) float64
        Parameterisation. Not modified.
    b : (k,) int64, optional
        Boundary loop, for the boundary measures.
    angle_bin_edges : (p + 1,) float64
        Histogram bins, degrees; default 0, 1, …, 180.
    beltrami_bin_edges : (q + 1,) float64
        Histogram bins of ``|μ|``; default 0, 0.02, …, 1.

    Returns
    -------
    MapQuality

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> q = map_quality(V, np.array([[0, 1, 2]]), V[:, :2] * 2)
    >>> q.angle_distortion_max, q.beltrami_max, q.flipped
    (0.0, 0.0, 0)
    """
    V = np.asarray(V, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V must have shape (n, 3), got {V.shape}")
    if uv.shape != (V.shape[0], 2):
        raise ValueError(f"uv must have shape ({V.shape[0]}, 2), got {uv.shape}")
    if F.ndim != 2 or F.shape[1] != 3 or F.shape[0] == 0:
        raise ValueError(f"F must have shape (m, 3) with m > 0, got {F.shape}")
    d = angle_distortion(V, F, uv).reshape(-1)
    mu = np.abs(beltrami_coefficient(V, F, uv))
    flips = int(flipped_triangles(uv, F).sum())
    if b is not None:
        b = np.asarray(b, dtype=np.int64)
        circle = float(np.abs(np.hypot(uv[b, 0], uv[b, 1]) - 1.0).max())
        iso = boundary_isoperimetric_ratio(uv, b)
    else:
        circle = iso = float("nan")
    finite_mu = mu[np.isfinite(mu)]
    return MapQuality(
        n_vertices=int(V.shape[0]),
        n_faces=int(F.shape[0]),
        angle_distortion_mean=float(d.mean()),
        angle_distortion_median=float(np.median(d)),
        angle_distortion_max=float(d.max()),
        angle_histogram=histogram(d, angle_bin_edges),
        beltrami_mean=float(finite_mu.mean()) if finite_mu.size else float("nan"),
        beltrami_median=float(np.median(finite_mu)) if finite_mu.size else float("nan"),
        beltrami_max=float(mu.max()),
        beltrami_histogram=histogram(mu, beltrami_bin_edges),
        flipped=flips,
        boundary_circle_error=circle,
        boundary_isoperimetric_ratio=iso,
    )
