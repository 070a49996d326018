"""``EXT_meshopt_compression`` for our GLBs: float attributes kept float, made smaller.

The morph GLBs are mostly morph-target deltas (float32 VEC3, 12 bytes a vertex a
target). meshoptimizer's vertex codec with its EXPONENTIAL filter stores each float as a
mantissa of ``bits`` bits with an exponent shared per component of the buffer view, and
the decoder (three.js ``MeshoptDecoder``, Babylon's built-in one) restores float32
values; the file keeps its meaning exactly as written otherwise: the same accessors
(float, not ``KHR_mesh_quantization`` integers), so the node's rest transform stays the
identity and the morph weights stay one-hot (quantized integer positions would need a
dequantization scale on a node or on the weights).

Precision: the mantissa bits of each buffer view are chosen from its own largest
magnitude so that the rounding error of a component is at most ``tolerance`` (a length
for positions: ``POSITION_TOLERANCE`` × the base mesh's bounding-box diagonal; a unit
for normal deltas: ``NORMAL_TOLERANCE``), capped at 24 bits (float32's own precision).
Index buffers use the lossless TRIANGLES codec; images and the animation's small
buffers are left as they are.

The compressed views live in the GLB's binary chunk; every view points at a second,
data-less buffer marked ``fallback`` (the extension's layout for a file that requires
it): tools without a meshopt decoder (Blender 4.5/5.0's importer, pygltflib readers,
trimesh) cannot read such a file, hence ``--compress none``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pygltflib as g
from numpy.typing import NDArray

EXTENSION = "EXT_meshopt_compression"
#: ``--compress`` choices: ``auto`` (meshopt when the uncompressed file would exceed
#: :data:`AUTO_MIN_BYTES`), ``meshopt`` always, ``none`` never
COMPRESS_CHOICES = ("auto", "meshopt", "none")
#: the one default of ``--compress``, the job field and the batch key
DEFAULT_COMPRESS = "auto"
#: ``auto`` compresses files that would be larger than this uncompressed (16 MiB): a
#: 7k-vertex face × 30 frames with normal targets (5 MB) stays readable everywhere
AUTO_MIN_BYTES = 16 << 20
#: largest rounding error of a position component, in bounding-box diagonals
POSITION_TOLERANCE = 2e-5
#: largest rounding error of a normal-delta component (unit vectors: 4e-3 ≈ 0.23°)
NORMAL_TOLERANCE = 4e-3
#: largest rounding error of a texture coordinate (a 4096-texel texture's 1/250 texel)
UV_TOLERANCE = 1e-6
#: largest rounding error of a colour component (1/8 of an 8-bit step)
COLOR_TOLERANCE = 1.0 / 2048.0


@dataclass(frozen=True)
class CompressedView:
    """A buffer view to compress: its float rows (or indices) and how."""

    view: int
    data: NDArray[Any]
    mode: str  # "ATTRIBUTES" (float rows, EXPONENTIAL filter) or "TRIANGLES"
    tolerance: float = 0.0


def check_compress(choice: str) -> str:
    """``choice`` if it is one of :data:`COMPRESS_CHOICES`, else a ``ValueError``."""
    if choice not in COMPRESS_CHOICES:
        raise ValueError(f"compress must be one of {', '.join(COMPRESS_CHOICES)}, got {choice!r}")
    return choice


def mantissa_bits(values: NDArray[np.float32], tolerance: float) -> int:
    """Mantissa bits keeping every component of ``values`` within ``tolerance``.

    With an exponent shared per component, a component of largest magnitude M is
    stored to M · 2^(1 − bits); the bits are the fewest (at least 8, at most 24) that
    bring that under ``tolerance``.
    """
    peak = float(np.abs(values).max(initial=0.0))
    if peak == 0.0 or tolerance <= 0.0:
        return 24 if peak else 8
    return int(np.clip(np.ceil(np.log2(peak / tolerance)) + 1, 8, 24))


def _encoded(item: CompressedView) -> tuple[bytes, dict[str, Any]]:
    """The compressed bytes of a view and its extension object (without offsets)."""
    import meshopt

    if item.mode == "TRIANGLES":
        idx = np.ascontiguousarray(item.data, dtype=np.uint32).reshape(-1)
        data = meshopt.encode_gltf_buffer(idx, "TRIANGLES", 1)
        return data, {"byteStride": 4, "count": int(idx.size), "mode": "TRIANGLES"}
    vals = np.ascontiguousarray(item.data, dtype=np.float32)
    bits = mantissa_bits(vals, item.tolerance)
    rows = meshopt.encode_filter_exp(vals, bits, "SharedComponent")
    data = meshopt.encode_gltf_buffer(rows, "ATTRIBUTES", 1)
    ext = {
        "byteStride": int(rows.shape[1]),
        "count": int(vals.shape[0]),
        "mode": "ATTRIBUTES",
        "filter": "EXPONENTIAL",
    }
    return data, ext


def _decoded_bounds(gltf: g.GLTF2, view: int, data: bytes, ext: dict[str, Any]) -> None:
    """Accessor ``min``/``max`` of a lossily compressed view set to what decoders will
    read (the glTF spec wants the bounds of the data as stored)."""
    if ext["mode"] != "ATTRIBUTES":
        return
    import meshopt

    rows = meshopt.decode_gltf_buffer(
        data, ext["count"], ext["byteStride"], "ATTRIBUTES", "EXPONENTIAL"
    )
    vals = np.ascontiguousarray(rows).view(np.float32).reshape(ext["count"], -1)
    for acc in gltf.accessors:
        if acc.bufferView == view and acc.min is not None:
            acc.min = [float(x) for x in vals.min(axis=0)]
            acc.max = [float(x) for x in vals.max(axis=0)]


def compress_glb(gltf: g.GLTF2, blob: bytes, views: list[CompressedView]) -> tuple[g.GLTF2, bytes]:
    """Move ``views`` into ``EXT_meshopt_compression`` streams; the rest stays as it was.

    Parameters
    ----------
    gltf : pygltflib.GLTF2
        The document, one buffer (the GLB's binary chunk ``blob``); changed in place.
    blob : bytes
        Its binary chunk.
    views : list of CompressedView
        The buffer views to compress, each with its decoded content: (count, k) float
        rows (``ATTRIBUTES``; the view must hold exactly those float32 rows, tightly
        packed) or indices (``TRIANGLES``).

    Returns
    -------
    gltf, blob
        The document (extension required; buffer 1 the data-less fallback) and the new
        binary chunk.
    """
    by_view = {v.view: v for v in views}
    out = bytearray()
    virtual = 0  # the fallback buffer's layout: the uncompressed views, 4-aligned
    for i, bv in enumerate(gltf.bufferViews):
        old = blob[bv.byteOffset or 0 : (bv.byteOffset or 0) + bv.byteLength]
        out.extend(b"\x00" * ((-len(out)) % 4))
        if i not in by_view:
            bv.byteOffset = len(out)
            out.extend(old)
            continue
        data, ext = _encoded(by_view[i])
        _decoded_bounds(gltf, i, data, ext)
        ext.update(buffer=0, byteOffset=len(out), byteLength=len(data))
        out.extend(data)
        virtual += (-virtual) % 4
        bv.buffer = 1
        bv.byteOffset = virtual
        if ext["mode"] == "ATTRIBUTES":
            bv.byteStride = ext["byteStride"] if bv.target == g.ARRAY_BUFFER else None
            bv.byteLength = ext["byteStride"] * ext["count"]
        virtual += bv.byteLength
        bv.extensions = {EXTENSION: ext}
    out.extend(b"\x00" * ((-len(out)) % 4))
    gltf.buffers = [
        g.Buffer(byteLength=len(out)),
        g.Buffer(byteLength=max(virtual, 4), extensions={EXTENSION: {"fallback": True}}),
    ]
    for name in ("extensionsUsed", "extensionsRequired"):
        got = list(getattr(gltf, name) or [])
        if EXTENSION not in got:
            got.append(EXTENSION)
        setattr(gltf, name, got)
    return gltf, bytes(out)
