"""``EXT_meshopt_compression`` for our GLBs.

Three kinds of buffer view are compressed with meshoptimizer's codecs (decoded by
three.js' ``MeshoptDecoder`` and Babylon's built-in one):

* float rows (``EXPONENTIAL`` filter): each float becomes a mantissa of ``bits`` bits with
  an exponent shared per component of the view, the bits chosen from the view's largest
  magnitude so that a component's rounding error is at most ``tolerance`` (a length for
  positions, a unit for normals), capped at 24 bits (float32's own precision);
* integer rows (no filter: ``KHR_mesh_quantization`` attributes, see
  :mod:`conformorph.pipelines.gltf_quantization`) and unit vectors (``OCTAHEDRAL``
  filter, 16-bit storage), stored as they are;
* triangle indices, losslessly (``TRIANGLES``), the triangles first put in the order a
  GPU's vertex cache likes (meshoptimizer's ``optimizeVertexCache``; each triangle and
  its winding kept, the vertex order unchanged: vertex i is still the input's vertex i).

Images and the animation's small buffers are left as they are.

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

from conformorph.pipelines.gltf_quantization import NORMAL_OCT_BITS

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
    mode: str  # "ATTRIBUTES" or "TRIANGLES"
    tolerance: float = 0.0
    #: ATTRIBUTES only: "EXPONENTIAL" (float rows, within ``tolerance``), "NONE" (integer
    #: rows as they are) or "OCTAHEDRAL" (``data`` unit vectors (n, 3), 16-bit storage)
    filter: str = "EXPONENTIAL"


def check_compress(choice: str) -> str:
    """``choice`` if it is one of :data:`COMPRESS_CHOICES`, else a ``ValueError``."""
    if choice not in COMPRESS_CHOICES:
        raise ValueError(f"compress must be one of {', '.join(COMPRESS_CHOICES)}, got {choice!r}")
    return choice


def compresses(choice: str, raw_bytes: int) -> bool:
    """Whether ``--compress choice`` compresses a file of ``raw_bytes`` uncompressed."""
    check_compress(choice)
    return choice == "meshopt" or (choice == "auto" and raw_bytes > AUTO_MIN_BYTES)


def cache_ordered_triangles(indices: NDArray[Any]) -> NDArray[np.uint32]:
    """Triangles reordered for the vertex cache (and the ``TRIANGLES`` codec).

    Parameters
    ----------
    indices : (3m,) uint32
        A triangle list.

    Returns
    -------
    (3m,) uint32
        The same triangles (each with its corners in the same cyclic order) in
        meshoptimizer's vertex-cache order; vertex indices are unchanged.
    """
    import meshopt

    idx = np.ascontiguousarray(indices, dtype=np.uint32).reshape(-1)
    renumbered, remap, unique = meshopt.reorder_mesh(idx, True, False)
    used = remap < unique  # unused vertices map to 0xFFFFFFFF
    original = np.zeros(unique, dtype=np.uint32)
    original[remap[used]] = np.flatnonzero(used)
    return original[renumbered]


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
        idx = cache_ordered_triangles(item.data)
        data = meshopt.encode_gltf_buffer(idx, "TRIANGLES", 1)
        return data, {"byteStride": 4, "count": int(idx.size), "mode": "TRIANGLES"}
    if item.filter != "EXPONENTIAL":
        if item.filter == "OCTAHEDRAL":
            unit = np.c_[np.asarray(item.data, dtype=np.float32), np.zeros(len(item.data))]
            rows = meshopt.encode_filter_oct(unit, 8, NORMAL_OCT_BITS)
        else:
            rows = np.ascontiguousarray(item.data).view(np.uint8).reshape(len(item.data), -1)
        data = meshopt.encode_gltf_buffer(rows, "ATTRIBUTES", 1)
        ext = {"byteStride": int(rows.shape[1]), "count": int(rows.shape[0]), "mode": "ATTRIBUTES"}
        if item.filter == "OCTAHEDRAL":
            ext["filter"] = "OCTAHEDRAL"
        return data, ext
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
    if ext["mode"] != "ATTRIBUTES" or ext.get("filter") != "EXPONENTIAL":
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
    from conformorph.geometry.threads import map_in_threads

    by_view = {v.view: v for v in views}
    # every view encoded first, on threads (the codec releases the GIL: one 1M-row view
    # in 0.18 s, two on two threads in 0.25 s)
    encoded = dict(zip(by_view, map_in_threads(_encoded, list(by_view.values())), strict=True))
    out = bytearray()
    virtual = 0  # the fallback buffer's layout: the uncompressed views, 4-aligned
    for i, bv in enumerate(gltf.bufferViews):
        old = blob[bv.byteOffset or 0 : (bv.byteOffset or 0) + bv.byteLength]
        out.extend(b"\x00" * ((-len(out)) % 4))
        if i not in by_view:
            bv.byteOffset = len(out)
            out.extend(old)
            continue
        data, ext = encoded[i]
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
