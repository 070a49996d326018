"""The morph targets of a morph GLB: float deltas, or quantized ones for compressed files.

One target per frame: position deltas ``frames_V[k] − base_V`` (normal and colour deltas
when asked). Plain files store float32 (dense, or sparse accessors); compressed files
store the normalized integers of :mod:`conformorph.pipelines.gltf_quantization` (position
deltas on the grid of a :class:`~conformorph.pipelines.gltf_quantization.PositionGrid`,
normal deltas as bytes, colour deltas as shorts), which the child node's transform
dequantizes (:func:`dequantization_nodes`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pygltflib as g
from numpy.typing import NDArray

from conformorph.pipelines.glb_builder import GlbBuilder
from conformorph.pipelines.gltf_compression import (
    COLOR_TOLERANCE,
    NORMAL_TOLERANCE,
    POSITION_TOLERANCE,
)
from conformorph.pipelines.gltf_quantization import (
    PositionGrid,
    normal_delta_rows,
    snorm16_rows,
)

#: the ``KHR_mesh_quantization`` extension name
QUANTIZATION = "KHR_mesh_quantization"


def position_tolerance(V: NDArray[np.float64]) -> float:
    """Largest rounding error compression may give a float position component of a mesh
    (:data:`conformorph.pipelines.gltf_compression.POSITION_TOLERANCE` × the bounding-box
    diagonal of ``V``; 1e-7 of the largest coordinate for a single point)."""
    diag = float(np.linalg.norm(np.ptp(V, axis=0)))
    return POSITION_TOLERANCE * diag if diag > 0 else 1e-7 * max(float(np.abs(V).max()), 1e-30)


@dataclass(frozen=True)
class TargetData:
    """What the targets hold (all arrays per frame).

    Attributes
    ----------
    frames_V : (T, n, 3) float64
        Every frame's positions.
    base_V : (n, 3) float64
        Base positions.
    frame_N : (T, n, 3) float64 or None
        Unit normals of every frame (None: no NORMAL targets).
    base_N : (n, 3) float64
        Unit base normals.
    frame_C : (T, n, 3|4) float64 or None
        Per-frame colours (None: no COLOR_0 targets).
    base_C : (n, 3|4) float64 or None
        Base colours.
    """

    frames_V: NDArray[np.float64]
    base_V: NDArray[np.float64]
    frame_N: NDArray[np.float64] | None
    base_N: NDArray[np.float64]
    frame_C: NDArray[np.float64] | None
    base_C: NDArray[np.float64] | None


def rebased(data: TargetData, k: int) -> TargetData:
    """``data`` with frame ``k`` as the base (positions, normals and per-frame colours;
    static colours stay), so that target j holds frame j minus frame k."""
    return replace(
        data,
        base_V=data.frames_V[k],
        base_N=data.base_N if data.frame_N is None else data.frame_N[k],
        base_C=data.base_C if data.frame_C is None else data.frame_C[k],
    )


def float_morph_targets(b: GlbBuilder, data: TargetData, sparse: bool) -> list[Any]:
    """One float32 morph target per frame: position (normal, colour) deltas to the base."""
    tol = position_tolerance(data.base_V)

    def add(a: NDArray[Any], ty: str, tol: float) -> int:
        if sparse:
            return b.sparse_accessor(a, ty)
        return b.accessor(a, ty, minmax=True, tolerance=tol)

    targets = []
    for k in range(data.frames_V.shape[0]):
        dV = (data.frames_V[k] - data.base_V).astype(np.float32)
        tgt = g.Attributes(POSITION=add(dV, g.VEC3, tol))
        if data.frame_N is not None:
            dN = (data.frame_N[k] - data.base_N).astype(np.float32)
            tgt.NORMAL = add(dN, g.VEC3, NORMAL_TOLERANCE)
        if data.frame_C is not None and data.base_C is not None:
            ty = g.VEC3 if data.base_C.shape[1] == 3 else g.VEC4
            dC = (data.frame_C[k] - data.base_C).astype(np.float32)
            tgt.COLOR_0 = add(dC, ty, COLOR_TOLERANCE)
        targets.append(tgt)
    return targets


def quantized_morph_targets(b: GlbBuilder, data: TargetData, grid: PositionGrid) -> list[Any]:
    """One morph target per frame as normalized integers (``KHR_mesh_quantization``).

    Position deltas: normalized SHORT in units of ``grid.scale`` (step ``grid.step``);
    normal deltas: normalized BYTE (:func:`~conformorph.pipelines.gltf_quantization.normal_delta_rows`);
    colour deltas: normalized SHORT in [−1, 1].
    """
    from conformorph.geometry.threads import map_in_threads

    def frame_rows(k: int) -> tuple[NDArray[Any], NDArray[Any] | None, NDArray[Any] | None]:
        dV = snorm16_rows(data.frames_V[k] - data.base_V, grid.scale)
        dN = dC = None
        if data.frame_N is not None:
            dN = normal_delta_rows(data.base_N, data.frame_N[k])
        if data.frame_C is not None and data.base_C is not None:
            dC = snorm16_rows(data.frame_C[k] - data.base_C, 1.0)
        return dV, dN, dC

    # the frames' integer rows on threads (numpy's passes over a 1M-vertex frame release
    # the GIL), then the accessors in frame order
    targets = []
    for dV, dN, dC in map_in_threads(frame_rows, list(range(data.frames_V.shape[0]))):
        tgt = g.Attributes(POSITION=b.int_accessor(dV, g.VEC3, minmax=True))
        if dN is not None:
            tgt.NORMAL = b.int_accessor(dN, g.VEC3)
        if dC is not None and data.base_C is not None:
            ty = g.VEC3 if data.base_C.shape[1] == 3 else g.VEC4
            tgt.COLOR_0 = b.int_accessor(dC, ty)
        targets.append(tgt)
    return targets


def dequantization_nodes(
    b: GlbBuilder, name: str, extras: dict[str, Any], grid: PositionGrid | None
) -> int:
    """The scene's nodes; returns the index of the node holding the mesh.

    Without ``grid``: node 0 holds mesh 0. With it: node 0 (named ``name``, with
    ``extras``; the rigid motion goes there, its rest transform the identity) has one
    child, node 1 (``name + "_quantized"``), which holds mesh 0 and the dequantization
    (translation ``grid.offset``, uniform scale ``grid.scale``), and the document
    requires ``KHR_mesh_quantization``.
    """
    if grid is None:
        b.gltf.nodes.append(g.Node(mesh=0, name=name, extras=dict(extras)))
        return 0
    b.gltf.nodes.append(g.Node(name=name, extras=dict(extras), children=[1]))
    b.gltf.nodes.append(
        g.Node(
            mesh=0,
            name=f"{name}_quantized",
            translation=[float(x) for x in grid.offset],
            scale=[float(grid.scale)] * 3,
            extras={"dequantization": "translation + scale · stored (KHR_mesh_quantization)"},
        )
    )
    for field in ("extensionsUsed", "extensionsRequired"):
        setattr(b.gltf, field, [*(getattr(b.gltf, field) or []), QUANTIZATION])
    return 1
