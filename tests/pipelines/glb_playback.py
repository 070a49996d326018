"""Play a morph GLB back in Python as three.js and Babylon do (for the tests).

Decodes accessors (float, normalized or plain integers, sparse), samples the LINEAR
animation channels at a time (weights, translation, slerped rotation, scale) and gives
the world positions and the shader's normals (base NORMAL plus weighted NORMAL deltas,
normalised, then rotated by the node) of the first mesh's first primitive. A mesh on a
child of node 0 (a quantized file's dequantization node) is placed by the child's static
transform, then by node 0's.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pygltflib as g

_DTYPES = {
    5120: np.int8,
    5121: np.uint8,
    5122: np.int16,
    5123: np.uint16,
    5125: np.uint32,
    5126: np.float32,
}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def _normalized(arr: np.ndarray, dtype: Any) -> np.ndarray:
    """glTF's normalized integer decoding: max(c / (2^(b-1) - 1), -1) or c / (2^b - 1)."""
    info = np.iinfo(dtype)
    return np.maximum(arr / float(info.max), -1.0)


def read_accessor(gl: g.GLTF2, index: int) -> np.ndarray:
    """Accessor ``index`` as (count, width) float64 (sparse and normalized decoded)."""
    blob = gl.binary_blob()
    a = gl.accessors[index]
    w = _WIDTH[a.type]
    dt = _DTYPES[a.componentType]
    if a.bufferView is None:
        out = np.zeros((a.count, w))
    else:
        bv = gl.bufferViews[a.bufferView]
        stride = bv.byteStride or np.dtype(dt).itemsize * w
        start = (bv.byteOffset or 0) + (a.byteOffset or 0)
        data = blob
        ext = (bv.extensions or {}).get("EXT_meshopt_compression")
        if ext is not None:  # decoded as three.js's MeshoptDecoder does
            import meshopt

            chunk = blob[ext["byteOffset"] : ext["byteOffset"] + ext["byteLength"]]
            decoded = meshopt.decode_gltf_buffer(
                chunk, ext["count"], ext["byteStride"], ext["mode"], ext.get("filter", "NONE")
            )
            if ext["mode"] == "ATTRIBUTES":
                data = np.ascontiguousarray(decoded).tobytes()
            else:  # indices: decoded as integers of the view's own width
                data = np.asarray(decoded).astype(dt).tobytes()
            start = a.byteOffset or 0
        raw = np.frombuffer(
            data,
            dtype=np.uint8,
            count=stride * (a.count - 1) + np.dtype(dt).itemsize * w,
            offset=start,
        )
        rows = np.lib.stride_tricks.as_strided(
            raw, shape=(a.count, np.dtype(dt).itemsize * w), strides=(stride, 1)
        )
        out = np.ascontiguousarray(rows).view(dt).reshape(a.count, w).astype(np.float64)
        if a.normalized:
            out = _normalized(out, dt)
    if a.sparse is not None:
        s = a.sparse
        ib = gl.bufferViews[s.indices.bufferView]
        vb = gl.bufferViews[s.values.bufferView]
        idx = np.frombuffer(
            blob,
            dtype=_DTYPES[s.indices.componentType],
            count=s.count,
            offset=(ib.byteOffset or 0) + (s.indices.byteOffset or 0),
        )
        vals = (
            np.frombuffer(
                blob,
                dtype=dt,
                count=s.count * w,
                offset=(vb.byteOffset or 0) + (s.values.byteOffset or 0),
            )
            .reshape(-1, w)
            .astype(np.float64)
        )
        if a.normalized:
            vals = _normalized(vals, dt)
        out = out.copy()
        out[idx] = vals
    return out


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _slerp(a: np.ndarray, b: np.ndarray, u: float) -> np.ndarray:
    d = float(np.dot(a, b))
    if d < 0:
        b, d = -b, -d
    if d > 0.9995:
        q = a + u * (b - a)
        return q / np.linalg.norm(q)
    th = np.arccos(d)
    return (np.sin((1 - u) * th) * a + np.sin(u * th) * b) / np.sin(th)


@dataclass
class MorphGlb:
    """A decoded morph GLB: base attributes, target deltas, animation samplers."""

    gl: g.GLTF2
    F: np.ndarray
    base_V: np.ndarray
    base_N: np.ndarray | None
    dV: list[np.ndarray]
    dN: list[np.ndarray | None]
    channels: dict[str, tuple[np.ndarray, np.ndarray]]

    @classmethod
    def load(cls, path: str | Path) -> MorphGlb:
        gl = g.GLTF2().load(str(path))
        prim = gl.meshes[0].primitives[0]
        F = read_accessor(gl, prim.indices).reshape(-1, 3).astype(np.int64)
        base_V = read_accessor(gl, prim.attributes.POSITION)
        base_N = (
            None if prim.attributes.NORMAL is None else read_accessor(gl, prim.attributes.NORMAL)
        )
        dV, dN = [], []
        for t in prim.targets or []:
            dV.append(read_accessor(gl, t["POSITION"]))
            dN.append(read_accessor(gl, t["NORMAL"]) if t.get("NORMAL") is not None else None)
        channels = {}
        for anim in gl.animations[:1]:
            for ch in anim.channels:
                s = anim.samplers[ch.sampler]
                assert s.interpolation == "LINEAR"
                channels[ch.target.path] = (
                    read_accessor(gl, s.input).reshape(-1),
                    read_accessor(gl, s.output),
                )
        return cls(gl, F, base_V, base_N, dV, dN, channels)

    def _sample(self, path: str, t: float) -> np.ndarray | None:
        if path not in self.channels:
            return None
        ts, out = self.channels[path]
        if path == "weights":
            out = out.reshape(ts.size, -1)
        i = int(np.clip(np.searchsorted(ts, t, side="right") - 1, 0, ts.size - 1))
        if i == ts.size - 1 or t <= ts[0]:
            return out[i if t > ts[0] else 0]
        u = (t - ts[i]) / (ts[i + 1] - ts[i])
        if path == "rotation":
            return _slerp(out[i], out[i + 1], u)
        return (1 - u) * out[i] + u * out[i + 1]

    def node_matrix(self, t: float) -> tuple[np.ndarray, np.ndarray, float | np.ndarray]:
        """(rotation 3×3, translation, scale) of the node at time t (rest values between)."""
        node = self.gl.nodes[0]
        tr = self._sample("translation", t)
        rot = self._sample("rotation", t)
        sc = self._sample("scale", t)
        tr = np.asarray(node.translation or [0, 0, 0], float) if tr is None else tr
        rot = np.asarray(node.rotation or [0, 0, 0, 1], float) if rot is None else rot
        sc = np.asarray(node.scale or [1, 1, 1], float) if sc is None else sc
        return _quat_matrix(rot), tr, sc

    def weights(self, t: float) -> np.ndarray:
        w = self._sample("weights", t)
        return np.asarray(self.gl.meshes[0].weights or [0.0] * len(self.dV)) if w is None else w

    def child_transform(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rotation 3×3, translation, scale) of node 0's child holding the mesh (static;
        the identity when node 0 holds the mesh itself)."""
        node = self.gl.nodes[0]
        if node.mesh is not None or not node.children:
            return np.eye(3), np.zeros(3), np.ones(3)
        child = self.gl.nodes[node.children[0]]
        rot = np.asarray(child.rotation or [0, 0, 0, 1], float)
        tr = np.asarray(child.translation or [0, 0, 0], float)
        return _quat_matrix(rot), tr, np.asarray(child.scale or [1, 1, 1], float)

    def positions(self, t: float) -> np.ndarray:
        """(n, 3) world positions at time t."""
        w = self.weights(t)
        P = self.base_V + sum(wk * d for wk, d in zip(w, self.dV, strict=True) if wk != 0)
        Rc, tc, sc_c = self.child_transform()
        P = (P * sc_c) @ Rc.T + tc
        R, tr, sc = self.node_matrix(t)
        return (P * sc) @ R.T + tr

    def shader_normals(self, t: float) -> np.ndarray:
        """(n, 3) unit world normals the viewer lights with at time t."""
        assert self.base_N is not None
        w = self.weights(t)
        N = self.base_N.copy()
        for wk, d in zip(w, self.dN, strict=True):
            if wk != 0 and d is not None:
                N = N + wk * d
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        Rc, _, sc_c = self.child_transform()
        N = (N / sc_c) @ Rc.T
        R, _, sc = self.node_matrix(t)
        N = (N / sc) @ R.T
        return N / np.linalg.norm(N, axis=1, keepdims=True)


def three_playback(path: Path, times: list[float]) -> dict[str, Any]:
    """three.js r187 playing ``path`` (``tools/gltf_three_playback.mjs`` in Node) at
    ``times``: its JSON with each frame's ``positions`` and ``normals`` as (n, 3) arrays.
    Skips the calling test when Node or the repository's npm ``three`` is missing."""
    import json
    import shutil
    import subprocess
    import tempfile

    import pytest

    root = Path(__file__).resolve().parents[2]
    node = shutil.which("node")
    if node is None or not (root / "node_modules" / "three").is_dir():
        pytest.skip("node / npm three not installed")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "three.json"
        proc = subprocess.run(
            [node, str(root / "tools" / "gltf_three_playback.mjs"), str(path), str(out)]
            + [repr(float(t)) for t in times],
            capture_output=True, text=True, cwd=root, timeout=120,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        got: dict[str, Any] = json.loads(out.read_text())
    n = got["vertex_count"]
    for frame in got["frames"]:
        for key in ("positions", "normals"):
            if frame[key] is not None:
                frame[key] = np.asarray(frame[key], dtype=np.float64).reshape(n, 3)
    return got
