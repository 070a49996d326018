"""One GLB's binary buffer, buffer views and accessors as they are built; written
atomically, optionally through ``EXT_meshopt_compression``
(:mod:`conformorph.pipelines.gltf_compression`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pygltflib as g
from numpy.typing import NDArray

from conformorph.pipelines.atomic_write import atomic_path
from conformorph.pipelines.gltf_compression import (
    CompressedView,
    compress_glb,
    compresses,
)
from conformorph.pipelines.gltf_quantization import SHORT_MAX

_FLOAT = g.FLOAT
_UINT = g.UNSIGNED_INT
#: glTF component types of the integer attributes (``KHR_mesh_quantization``)
_INT_TYPES = {
    np.dtype(np.int8): g.BYTE,
    np.dtype(np.uint8): g.UNSIGNED_BYTE,
    np.dtype(np.int16): g.SHORT,
    np.dtype(np.uint16): g.UNSIGNED_SHORT,
}
_WIDTHS = {g.SCALAR: 1, g.VEC2: 2, g.VEC3: 3, g.VEC4: 4}


def glb_bytes(gltf: g.GLTF2, blob: bytes) -> bytes:
    """The GLB container of a document and its binary chunk (buffer 0), as written.

    Unlike ``pygltflib.GLTF2.save_binary``, which packs every buffer into the binary
    chunk, the document's buffers are kept as they are (an ``EXT_meshopt_compression``
    fallback buffer has no data).
    """
    import struct

    js = gltf.gltf_to_json(separators=(",", ":"), indent=None).encode("utf-8")
    js += b" " * ((-len(js)) % 4)
    bin_ = blob + b"\x00" * ((-len(blob)) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_)
    return b"".join(
        [
            struct.pack("<4sII", b"glTF", 2, total),
            struct.pack("<I4s", len(js), b"JSON"),
            js,
            struct.pack("<I4s", len(bin_), b"BIN\x00"),
            bin_,
        ]
    )


class GlbBuilder:
    """Accumulates one binary buffer, its buffer views and accessors."""

    def __init__(self) -> None:
        self.blob = bytearray()
        self.gltf = g.GLTF2(asset=g.Asset(version="2.0", generator="conformorph"))
        #: views ``save`` may compress: vertex data with its rounding tolerance, indices
        self.compressible: list[CompressedView] = []

    def view(self, data: bytes, target: int | None = None, stride: int | None = None) -> int:
        pad = (-len(self.blob)) % 4
        self.blob.extend(b"\x00" * pad)
        offset = len(self.blob)
        self.blob.extend(data)
        self.gltf.bufferViews.append(
            g.BufferView(
                buffer=0, byteOffset=offset, byteLength=len(data), target=target, byteStride=stride
            )
        )
        return len(self.gltf.bufferViews) - 1

    def int_accessor(
        self, rows: NDArray[Any], type_: str, *, minmax: bool = False, octahedral: Any = None
    ) -> int:
        """A normalized integer vertex attribute (``KHR_mesh_quantization``), compressible.

        Parameters
        ----------
        rows : (n, k) int8, uint8, int16 or uint16
            The values, each row padded to a multiple of 4 bytes (the view's stride).
        type_ : str
            ``VEC2``, ``VEC3`` or ``VEC4``: the first columns of each row.
        minmax : bool
            Give the accessor ``min``/``max`` (integers, as stored).
        octahedral : (n, 3) float array, optional
            The unit vectors ``rows`` hold: the view is then compressed with the
            ``OCTAHEDRAL`` filter from these (``rows`` are int16 (n, 4)).
        """
        rows = np.ascontiguousarray(rows)
        width = _WIDTHS[type_]
        view = self.view(rows.tobytes(), g.ARRAY_BUFFER, stride=rows.itemsize * rows.shape[1])
        acc = g.Accessor(
            bufferView=view,
            byteOffset=0,
            componentType=_INT_TYPES[rows.dtype],
            normalized=True,
            count=int(rows.shape[0]),
            type=type_,
        )
        if minmax:
            acc.min = [int(x) for x in rows[:, :width].min(axis=0)]
            acc.max = [int(x) for x in rows[:, :width].max(axis=0)]
        self.gltf.accessors.append(acc)
        if octahedral is None:
            self.compressible.append(CompressedView(view, rows, "ATTRIBUTES", filter="NONE"))
        else:
            unit = np.asarray(octahedral, dtype=np.float64)
            self.compressible.append(CompressedView(view, unit, "ATTRIBUTES", filter="OCTAHEDRAL"))
        return len(self.gltf.accessors) - 1

    def unit_vector_accessor(self, N: NDArray[np.float64]) -> int:
        """Unit vectors (n, 3) as normalized SHORT VEC3 rows, ``OCTAHEDRAL``-compressed."""
        rows = np.zeros((N.shape[0], 4), dtype=np.int16)
        rows[:, :3] = np.rint(np.clip(N, -1.0, 1.0) * SHORT_MAX)
        return self.int_accessor(rows, g.VEC3, octahedral=N)

    def accessor(
        self,
        arr: NDArray[Any],
        type_: str,
        *,
        target: int | None = g.ARRAY_BUFFER,
        minmax: bool = False,
        tolerance: float | None = None,
    ) -> int:
        """An accessor of ``arr`` (uint32 kept, anything else float32) in a view of its own.

        ``tolerance``: the view may be compressed with rounding errors up to this
        (float data); index views (``ELEMENT_ARRAY_BUFFER``) are compressed losslessly.
        """
        if arr.dtype == np.uint32:
            ctype = _UINT
        else:
            arr = arr.astype(np.float32)
            ctype = _FLOAT
        arr = np.ascontiguousarray(arr)
        count = arr.shape[0]
        acc = g.Accessor(
            bufferView=self.view(arr.tobytes(), target),
            byteOffset=0,
            componentType=ctype,
            count=count,
            type=type_,
        )
        if minmax:
            flat = arr.reshape(count, -1)
            acc.min = [float(x) for x in flat.min(axis=0)]
            acc.max = [float(x) for x in flat.max(axis=0)]
        self.gltf.accessors.append(acc)
        if tolerance is not None and ctype == _FLOAT and arr.ndim == 2:
            self.compressible.append(CompressedView(acc.bufferView, arr, "ATTRIBUTES", tolerance))
        elif target == g.ELEMENT_ARRAY_BUFFER and count % 3 == 0:
            self.compressible.append(CompressedView(acc.bufferView, arr, "TRIANGLES"))
        return len(self.gltf.accessors) - 1

    def sparse_accessor(self, arr: NDArray[Any], type_: str) -> int:
        """A float accessor of zeros with the non-zero rows of ``arr`` stored sparsely."""
        arr = np.ascontiguousarray(arr, dtype=np.float32)
        count = arr.shape[0]
        rows = np.flatnonzero(np.any(arr != 0.0, axis=1)).astype(np.uint32)
        if rows.size == 0:
            rows = np.array([0], dtype=np.uint32)  # sparse.count must be ≥ 1
        idx_view = self.view(rows.tobytes())
        val_view = self.view(np.ascontiguousarray(arr[rows]).tobytes())
        acc = g.Accessor(
            bufferView=None,
            byteOffset=None,
            componentType=_FLOAT,
            count=count,
            type=type_,
            min=[float(x) for x in arr.min(axis=0)],
            max=[float(x) for x in arr.max(axis=0)],
            sparse=g.Sparse(
                count=int(rows.size),
                indices=g.AccessorSparseIndices(
                    bufferView=idx_view, byteOffset=0, componentType=_UINT
                ),
                values=g.AccessorSparseValues(bufferView=val_view, byteOffset=0),
            ),
        )
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1

    def save(self, path: str | Path, compress: str = "none") -> int:
        """Write the GLB atomically (temporary file, then rename); returns its size.

        ``compress``: ``"meshopt"`` moves the compressible views into
        ``EXT_meshopt_compression`` streams, ``"auto"`` does when the file would
        otherwise exceed
        :data:`conformorph.pipelines.gltf_compression.AUTO_MIN_BYTES`, ``"none"`` never.
        """
        pad = (-len(self.blob)) % 4
        self.blob.extend(b"\x00" * pad)
        self.gltf.buffers = [g.Buffer(byteLength=len(self.blob))]
        blob = bytes(self.blob)
        packed = None
        if compresses(compress, len(blob)) and self.compressible:
            self.gltf, blob = compress_glb(self.gltf, blob, self.compressible)
            packed = glb_bytes(self.gltf, blob)  # pygltflib would merge the two buffers
        else:
            self.gltf.set_binary_blob(blob)
        path = Path(path)
        with atomic_path(path) as tmp:  # created with the umask's mode (0644), then renamed
            if packed is None:
                self.gltf.save_binary(str(tmp))
            else:
                tmp.write_bytes(packed)
        return path.stat().st_size
