"""Where a 2D morph sits in its GLB: metres, centred at the origin, Y up.

glTF lengths are metres and its Y axis points up. The 2D pipeline's shapes are already
Y up (:mod:`conformorph.pipelines.shape_io` flips the SVG's y-down user space), in SVG user
units, which are CSS pixels (96 per inch). The 2D GLBs place every frame by one map,

    X = s · (x − c_x),   Y = s · (y − c_y),   Z = 0,

with ``c`` the centre of the bounding box of all frames together (the whole animation
is centred, and a shape that moves keeps its motion) and ``s`` metres per SVG unit:
``METRES_PER_SVG_UNIT[units]`` (default ``"px"``: 0.0254 / 96 m, the CSS pixel), or, with
``size``, the factor that makes the larger side of that box ``size`` metres. Triangles
clockwise seen from +z are re-wound so that the normals face the viewer. The SVG
outputs (``strip.svg``, ``animation.svg``) and ``frames.json`` keep SVG units.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: metres per SVG user unit when the SVG's numbers are in each of these units
METRES_PER_SVG_UNIT: dict[str, float] = {
    "px": 0.0254 / 96.0,
    "pt": 0.0254 / 72.0,
    "in": 0.0254,
    "mm": 1e-3,
    "cm": 1e-2,
    "m": 1.0,
}
#: the one default of ``morph2d --units`` and the job field ``units``: CSS pixels, 96 dpi
DEFAULT_SVG_UNITS = "px"


@dataclass(frozen=True)
class GlbPlacement:
    """How 2D frames are placed in a GLB.

    Attributes
    ----------
    units : str
        What one SVG user unit is (a key of :data:`METRES_PER_SVG_UNIT`). Default
        :data:`DEFAULT_SVG_UNITS`.
    size : float or None
        The larger side of all frames' bounding box, in metres, instead of ``units``.
        Default None.
    """

    units: str = DEFAULT_SVG_UNITS
    size: float | None = None

    def __post_init__(self) -> None:
        if self.units not in METRES_PER_SVG_UNIT:
            raise ValueError(
                f"units must be one of {', '.join(METRES_PER_SVG_UNIT)}, got {self.units!r}"
            )
        if self.size is not None and not (np.isfinite(self.size) and self.size > 0):
            raise ValueError(f"size must be a positive number of metres, got {self.size}")


def placed_2d_frames(
    frames: NDArray[np.float64], F: NDArray[np.int64], placement: GlbPlacement | None = None
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """2D frames (Y up) in metres, centred, at z = 0, with their triangles wound for +z.

    Parameters
    ----------
    frames : (T, n, 2) float64
        Frames in SVG user units, Y up.
    F : (m, 3) int64
        Triangles.
    placement : GlbPlacement, optional (default ``GlbPlacement()``)

    Returns
    -------
    frames_m : (T, n, 3) float64
        The placed frames (metres).
    F_out : (m, 3) int64
        ``F``, or ``F`` with two corners swapped when its triangles are clockwise seen
        from +z (signed area of frame 0 summed).
    report : dict
        ``{"units", "metres_per_unit", "centre": [x, y] (SVG units), "size_m": [w, h]}``.
    """
    placement = GlbPlacement() if placement is None else placement
    fr = np.asarray(frames, dtype=np.float64)
    if fr.ndim != 3 or fr.shape[2] != 2 or fr.shape[0] == 0 or fr.shape[1] == 0:
        raise ValueError(f"frames must have shape (T, n, 2), got {fr.shape}")
    lo, hi = fr.reshape(-1, 2).min(axis=0), fr.reshape(-1, 2).max(axis=0)
    centre = (lo + hi) / 2.0
    extent = float((hi - lo).max())
    if placement.size is not None:
        if extent <= 0:
            raise ValueError("the frames have no extent to scale to a size")
        s = placement.size / extent
    else:
        s = METRES_PER_SVG_UNIT[placement.units]
    out = np.zeros(fr.shape[:2] + (3,))
    out[..., 0] = s * (fr[..., 0] - centre[0])
    out[..., 1] = s * (fr[..., 1] - centre[1])
    Fo = np.asarray(F, dtype=np.int64)
    P = out[0]
    a, b, c = P[Fo[:, 0]], P[Fo[:, 1]], P[Fo[:, 2]]
    signed = np.sum(
        (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    )
    if signed < 0:
        Fo = Fo[:, [0, 2, 1]]
    report = {
        "units": placement.units if placement.size is None else "size",
        "metres_per_unit": s,
        "centre": [float(x) for x in centre],
        "size_m": [float(x) for x in (hi - lo) * s],
    }
    return out, Fo, report
