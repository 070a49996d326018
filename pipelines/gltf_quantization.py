"""``KHR_mesh_quantization`` for the compressed morph GLB: integer morph-target deltas.

A morph GLB is mostly morph targets (one per frame). When it is compressed
(:mod:`conformorph.pipelines.gltf_compression`) its targets are stored as small
normalized integers, which meshoptimizer's vertex codec packs far better than floats:

* **Position deltas**: normalized ``SHORT`` (VEC3 padded to 8 bytes), ``d ≈ q / 32767 · S``
  on a grid of step ``s = S / 32767``. The dequantization (translation ``O``, uniform
  scale ``S``) sits on a child node that holds the mesh; the node above it keeps the
  names, the rigid motion and an identity rest transform. The base ``POSITION`` stays
  float (``(V − O) / S``, ``EXPONENTIAL`` filter, nearly exact): the error budget goes to
  the deltas.
* **Normal deltas**: normalized ``BYTE`` (VEC3 padded to 4 bytes), step 1/127. A viewer
  lights with ``normalize(N_base + Σ w_k ΔN_k)``, so a target may hold
  ``λ N_k − N_base`` for any ``λ > 0`` and still give frame k's normal exactly at its key;
  ``λ = 1`` except where a component would leave [−1, 1] (normals turned by more than
  60°), where ``λ`` is the largest value that fits.
* **Base normals**: unit vectors through the ``OCTAHEDRAL`` filter (normalized ``SHORT``).
* **Colours**: base ``COLOR_0`` normalized ``UNSIGNED_SHORT``; colour deltas normalized
  ``SHORT`` (deltas are signed).

Base frame. The deltas' entropy grows with their size, so the compressed file's base mesh
is the frame nearest the frames' mean (:func:`central_frame`, the middle of a two-key
morph) rather than frame 0: the targets are about half as long (two 68k-vertex faces ×
30 frames: position and normal targets 6.7 → 5.4 MB). ``mesh.weights`` still select
frame 0, so a viewer shows frame 0 at rest.

Error bound. With ``e_b`` the base's largest component error and ``s`` the delta step,
every decoded vertex at any time (at most two targets active, weights summing to at
most 1) lies within ``√3 (e_b + s / 2)`` of the float file's. ``position_grid`` picks
``e_b`` as 1/8 of the budget and ``s`` for the rest, the budget being
:data:`POSITION_ERROR` times the smallest bounding-box diagonal over the frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: largest distance of a decoded vertex from the float file's, in bounding-box diagonals
#: (the smallest diagonal over the frames)
POSITION_ERROR = 1e-4
#: largest normalized SHORT value
SHORT_MAX = 32767
#: largest normalized BYTE value
BYTE_MAX = 127
#: octahedral bits of the base normals (in 16-bit storage): about 0.03° of error
NORMAL_OCT_BITS = 12


@dataclass(frozen=True)
class PositionGrid:
    """Where the quantized positions live: ``world = offset + scale · stored``.

    Attributes
    ----------
    offset : (3,) float64
        The child node's translation: the centre of the base's bounding box.
    scale : float
        The child node's uniform scale ``S``: a stored delta of ``q / 32767`` is
        ``q / 32767 · S`` long.
    step : float
        The deltas' grid step ``S / 32767`` (model units).
    base_tolerance : float
        Largest error of a base position component (model units).
    error_bound : float
        Largest distance of any decoded vertex from the exact one, ``√3 (base_tolerance
        + step / 2)`` (model units).
    """

    offset: NDArray[np.float64]
    scale: float
    step: float
    base_tolerance: float
    error_bound: float


def position_grid(base_V: NDArray[np.float64], frames_V: NDArray[np.float64]) -> PositionGrid:
    """The grid of the position deltas of a morph (see the module's error bound).

    Parameters
    ----------
    base_V : (n, 3) float64
        Base positions.
    frames_V : (T, n, 3) float64
        Every frame's positions (target k holds ``frames_V[k] − base_V``).

    Returns
    -------
    PositionGrid
        The step meets :data:`POSITION_ERROR` times the smallest bounding-box diagonal
        over the base and the frames, unless some delta is longer than 32767 steps (about
        3.3 diagonals): then the step is the longest delta / 32767, coarser, and
        ``error_bound`` says by how much.
    """
    from conformorph.geometry.threads import map_in_threads

    def frame_extent(f: NDArray[np.float64]) -> tuple[float, float]:
        """A frame's diagonal and longest delta from the base (frame by frame, on
        threads: a (T, n, 3) temporary is 0.7 GB for 30 frames of a 1M-vertex mesh)."""
        return float(np.linalg.norm(np.ptp(f, axis=0))), float(np.abs(f - base_V).max(initial=0.0))

    extents = map_in_threads(frame_extent, list(frames_V))
    diag = min([float(np.linalg.norm(np.ptp(base_V, axis=0)))] + [d for d, _ in extents])
    if not diag > 0:  # a single point: any positive scale
        diag = max(float(np.abs(base_V).max()), 1.0)
    budget = POSITION_ERROR * diag / np.sqrt(3.0)
    base_tol = budget / 8.0
    step = 2.0 * (budget - base_tol)
    longest = max((x for _, x in extents), default=0.0)
    step = max(step, longest / SHORT_MAX)  # 32767 steps must reach the longest delta
    offset = (base_V.min(axis=0) + base_V.max(axis=0)) / 2.0
    return PositionGrid(
        offset=offset,
        scale=step * SHORT_MAX,
        step=step,
        base_tolerance=base_tol,
        error_bound=float(np.sqrt(3.0) * (base_tol + step / 2.0)),
    )


def snorm16_rows(values: NDArray[np.float64], unit: float, width: int = 4) -> NDArray[np.int16]:
    """``values / unit`` rounded to normalized SHORT integers, padded to ``width`` columns.

    Parameters
    ----------
    values : (n, k) float64
        Values with ``|values| ≤ unit`` (rounding keeps them in range; larger ones clip).
    unit : float
        The value stored as 32767 (decoded as 1.0).
    width : int
        Columns of the result (``k`` plus zero padding to a 4-byte multiple).

    Returns
    -------
    rows : (n, width) int16
    """
    rows = np.zeros((values.shape[0], width), dtype=np.int16)
    q = np.rint(values / unit * SHORT_MAX)
    rows[:, : values.shape[1]] = np.clip(q, -SHORT_MAX, SHORT_MAX)
    return rows


def unorm16_rows(values: NDArray[np.float64], width: int = 4) -> NDArray[np.uint16]:
    """Values in [0, 1] as normalized UNSIGNED_SHORT integers, padded to ``width`` columns.

    Parameters
    ----------
    values : (n, k) float64
    width : int

    Returns
    -------
    rows : (n, width) uint16
    """
    rows = np.zeros((values.shape[0], width), dtype=np.uint16)
    rows[:, : values.shape[1]] = np.rint(np.clip(values, 0.0, 1.0) * 65535.0)
    return rows


def normal_delta_rows(
    base_N: NDArray[np.float64], frame_N: NDArray[np.float64]
) -> NDArray[np.int8]:
    """One frame's NORMAL target as normalized BYTE rows (see the module's λ).

    Parameters
    ----------
    base_N : (n, 3) float64
        Unit base normals.
    frame_N : (n, 3) float64
        Unit normals of the frame.

    Returns
    -------
    rows : (n, 4) int8
        ``λ N_k − N_base`` in units of 1/127, the fourth column zero; ``λ = 1`` where that
        fits in [−1, 1], else the largest ``λ`` that does (one always does: ``λ = 0``).
    """
    lam = np.ones(base_N.shape[0])
    # per component: λ n − b ∈ [−1, 1]  ⇔  λ n ∈ [b − 1, b + 1]; bounds on λ where n ≠ 0
    for c in range(3):
        n, b = frame_N[:, c], base_N[:, c]
        with np.errstate(divide="ignore", invalid="ignore"):
            hi = np.where(n > 0, (b + 1.0) / n, np.where(n < 0, (b - 1.0) / n, np.inf))
        lam = np.minimum(lam, np.maximum(hi, 0.0))
    delta = lam[:, None] * frame_N - base_N
    rows = np.zeros((base_N.shape[0], 4), dtype=np.int8)
    rows[:, :3] = np.clip(np.rint(delta * BYTE_MAX), -BYTE_MAX, BYTE_MAX)
    return rows


def central_frame(frames_V: NDArray[np.float64]) -> int:
    """The frame nearest the frames' mean (least squares over all vertices).

    Parameters
    ----------
    frames_V : (T, n, 3) float64

    Returns
    -------
    int
        Its index (the first of equals).
    """
    from conformorph.geometry.threads import map_in_threads

    mean = frames_V.mean(axis=0)
    # frame by frame on threads (a 1M-vertex frame is 24 MB)
    return int(np.argmin(map_in_threads(lambda f: float(((f - mean) ** 2).sum()), list(frames_V))))
