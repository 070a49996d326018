"""Quality measures of a 2D morph sequence: flips, squeezing, strain monotonicity."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ._typing import FloatArray, IntArray
from .green_lagrange_strain import (
    deformation_gradient,
    shape_function_gradients,
    strain_from_gradient,
)
from .morph_pacing import path_steps
from .tolerances import MONOTONE_STRAIN_ATOL

#: Allowed relative overshoot of a triangle's area ratio beyond the interval
#: between 1 and its final ratio (the issue's "within 5%" no-squeezing rule).
SQUEEZE_TOLERANCE = 0.05

#: A strain component still counts as monotone when its total movement against
#: its own net direction is at most this fraction of the triangle's largest
#: strain change (all components). A tiny, invisible wobble of a component that
#: hardly changes (e.g. the cross-section strain of a bent bar, 1e-5 against a
#: length strain of 0.17) is not squeezing.
MONOTONE_STRAIN_RTOL = 0.01


@dataclass(frozen=True)
class MorphMetrics2D:
    """Measures of one morph sequence (T frames, m triangles).

    Attributes
    ----------
    flipped_per_frame : tuple of int
        Triangles with non-positive signed area in each frame.
    min_area_ratio, max_area_ratio : float
        Extremes of ``area_t / area_source`` over all triangles and frames.
    monotone_strain_fraction : float
        Fraction of triangles whose three strain components (eq. 1, source
        axes) each change monotonically over the sequence: the total movement
        of a component against its net direction must not exceed
        ``max(MONOTONE_STRAIN_ATOL, MONOTONE_STRAIN_RTOL × s_f)``, s_f the
        largest change of any strain component of that triangle.
    no_squeeze_fraction : float
        Fraction of triangles whose area ratio stays within 5% of the interval
        between 1 and its own final ratio through the whole sequence.
    max_squeeze_excess : float
        Largest relative excursion of an area ratio outside that interval
        (0 when every ratio stays inside it); no squeezing ⇔ ≤ 0.05.
    max_step_ratio : float
        Pacing: the largest move of any vertex between two consecutive frames,
        divided by the mean over the frame pairs of that largest move (1 for an
        evenly paced morph, e.g. uniform growth; much more when the shape holds
        still and then snaps, as eq. (3) does on large shears). 1 for fewer
        than three frames or a sequence that does not move.
    max_step_frame : int
        The frame that the largest move ends at (0 when nothing moves).
    """

    flipped_per_frame: tuple[int, ...]
    min_area_ratio: float
    max_area_ratio: float
    monotone_strain_fraction: float
    no_squeeze_fraction: float
    max_squeeze_excess: float
    max_step_ratio: float = 1.0
    max_step_frame: int = 0

    @property
    def total_flipped(self) -> int:
        """Sum of flipped triangles over all frames."""
        return int(sum(self.flipped_per_frame))

    @property
    def no_squeezing(self) -> bool:
        """Whether every triangle satisfies the 5% no-squeezing rule."""
        return self.max_squeeze_excess <= SQUEEZE_TOLERANCE

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (lists and floats only)."""
        d = asdict(self)
        d["flipped_per_frame"] = list(self.flipped_per_frame)
        d["total_flipped"] = self.total_flipped
        d["no_squeezing"] = self.no_squeezing
        return d


def morph_metrics_2d(source_V: FloatArray, F: IntArray, frames: FloatArray) -> MorphMetrics2D:
    """Measure flips, area ratios, squeezing and strain monotonicity of a 2D morph.

    Parameters
    ----------
    source_V : (n, 2) float64
        Source positions; areas and strains are measured against it.
    F : (m, 3) int64
        Triangles, counter-clockwise in ``source_V``.
    frames : (T, n, 2) float64
        The sequence; the last frame is taken as the target.

    Returns
    -------
    MorphMetrics2D

    Notes
    -----
    The area ratio of triangle f in frame t is ``det J_f(t)``, J the
    deformation gradient from the source. With ``r_f = det J_f(1)``, the
    no-squeezing rule asks ``0.95 min(1, r_f) ≤ det J_f(t) ≤ 1.05 max(1, r_f)``
    for all t; the excess is ``max((lo − r)/lo, (r − hi)/hi, 0)``. All measures
    are invariant under rigid motion and uniform scaling of the whole sequence
    together with the source.

    Examples
    --------
    >>> import numpy as np
    >>> V = np.array([[0.0, 0], [1, 0], [0, 1]])
    >>> seq = np.stack([V, 1.5 * V, 2 * V])  # uniform growth: monotone, no squeezing
    >>> m = morph_metrics_2d(V, np.array([[0, 1, 2]]), seq)
    >>> m.max_area_ratio, m.monotone_strain_fraction, m.no_squeezing, m.max_step_ratio
    (4.0, 1.0, True, 1.0)
    """
    frames = np.asarray(frames, dtype=np.float64)
    source_V = np.asarray(source_V, dtype=np.float64)
    if frames.ndim != 3 or frames.shape[1:] != source_V.shape or frames.shape[0] < 1:
        raise ValueError(f"frames must have shape (T, {source_V.shape[0]}, 2), got {frames.shape}")
    dN, _area = shape_function_gradients(source_V, F)
    F = np.asarray(F, dtype=np.int64)
    T = frames.shape[0]
    m = F.shape[0]
    ratio = np.zeros((T, m))
    strain = np.zeros((T, m, 3))
    for i in range(T):
        J = deformation_gradient(dN, frames[i], F)
        ratio[i] = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
        strain[i] = strain_from_gradient(J)
    flipped = tuple(int(k) for k in np.sum(ratio <= 0.0, axis=1))
    final = ratio[-1]
    lo = np.minimum(1.0, final)
    hi = np.maximum(1.0, final)
    with np.errstate(divide="ignore", invalid="ignore"):
        below = np.where(lo > 0, (lo[None] - ratio) / lo[None], np.inf)
        above = (ratio - hi[None]) / hi[None]
    excess = np.maximum(np.maximum(below, above), 0.0).max(axis=0)
    d = np.diff(strain, axis=0)  # (T-1, m, 3)
    # total movement against the component's own direction, (m, 3)
    backtrack = np.minimum(np.maximum(-d, 0.0).sum(axis=0), np.maximum(d, 0.0).sum(axis=0))
    scale = np.ptp(strain, axis=0).max(axis=1) if T > 1 else np.zeros(m)
    allowed = np.maximum(MONOTONE_STRAIN_ATOL, MONOTONE_STRAIN_RTOL * scale)
    monotone = np.all(backtrack <= allowed[:, None], axis=1)
    steps = path_steps(frames)
    mean_step = float(steps.mean()) if steps.size else 0.0
    step_ratio = float(steps.max()) / mean_step if T > 2 and mean_step > 0 else 1.0
    return MorphMetrics2D(
        flipped_per_frame=flipped,
        min_area_ratio=float(ratio.min()),
        max_area_ratio=float(ratio.max()),
        monotone_strain_fraction=float(monotone.mean()),
        no_squeeze_fraction=float(np.mean(excess <= SQUEEZE_TOLERANCE)),
        max_squeeze_excess=float(excess.max()),
        max_step_ratio=step_ratio,
        max_step_frame=int(np.argmax(steps)) + 1 if mean_step > 0 else 0,
    )
