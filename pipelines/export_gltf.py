"""glTF 2.0 (GLB) export of morph sequences and single frames, written with pygltflib.

One GLB per morph (see ``../shared/FACTS.md``, "glTF delivery"):

* the base mesh (``POSITION``, ``NORMAL``, optional ``COLOR_0``, ``TEXCOORD_0``
  and a PNG base-colour texture);
* one morph target per frame holding position deltas (optional normal and
  colour deltas), named in ``mesh.extras.targetNames``;
* a ``weights`` animation whose keys are one-hot vectors with LINEAR
  interpolation, so at most two consecutive targets are non-zero at any time
  (the spec guarantees viewers only 8 morphed attributes at once);
* the base mesh's smooth (area-weighted) unit vertex normals are always
  written: without ``NORMAL`` the spec makes viewers shade every face flat
  (Blender does), while others compute their own smooth normals (Babylon), so
  the same file would look different; NORMAL deltas ride on the targets when
  the morph changes the normals (``MorphAppearance(normals=True)``, the default);
* optionally the rigid part of the motion on the node's translation /
  rotation (/ scale) channels (glTF applies morphs before the node transform);
* every animation-sampler input accessor carries ``min``/``max``;
* compressed (``EXT_meshopt_compression``), the targets are quantized
  (``KHR_mesh_quantization``) and the mesh hangs on a child of node 0 whose static
  translation and scale dequantize it (:mod:`conformorph.pipelines.glb_morph_targets`).

Sparse targets (``sparse=True``) store only vertices that move; a target with
no moving vertex still lists one (zero) element, because a sparse accessor
needs ``count > 0``, and ``byteOffset`` is left unset when there is no buffer
view (a pygltflib default otherwise makes the Khronos validator report an
error). Every file is written atomically (temporary file, then rename).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pygltflib as g
from numpy.typing import ArrayLike, NDArray

from conformorph.pipelines.glb_builder import GlbBuilder
from conformorph.pipelines.glb_morph_targets import (
    TargetData,
    dequantization_nodes,
    float_morph_targets,
    position_tolerance,
    quantized_morph_targets,
    rebased,
)
from conformorph.pipelines.glb_normals import changed_normals, unit_vertex_normals
from conformorph.pipelines.gltf_compression import (
    COLOR_TOLERANCE,
    NORMAL_TOLERANCE,
    UV_TOLERANCE,
    compresses,
)
from conformorph.pipelines.gltf_quantization import (
    PositionGrid,
    central_frame,
    position_grid,
    unorm16_rows,
)


def _as_positions(V: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = np.asarray(V, dtype=np.float64)
    if arr.ndim == 2 and arr.shape[1] == 2:
        arr = np.c_[arr, np.zeros(arr.shape[0])]
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise ValueError(f"{name} must have shape (n, 3) (or (n, 2) for z = 0), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} has non-finite coordinates")
    return arr


def _as_faces(F: ArrayLike, n: int) -> NDArray[np.uint32]:
    arr = np.asarray(F)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] == 0:
        raise ValueError(f"F must have shape (m, 3) with m > 0, got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(f"F must be an integer array, got dtype {arr.dtype}")
    if arr.min() < 0 or arr.max() >= n:
        raise ValueError(f"face indices must lie in [0, {n}), got [{arr.min()}, {arr.max()}]")
    return arr.astype(np.uint32)


def _as_colors(colors: ArrayLike, shape_prefix: tuple[int, ...]) -> NDArray[np.float64]:
    arr = np.asarray(colors, dtype=np.float64)
    if arr.shape[:-1] != shape_prefix or arr.shape[-1] not in (3, 4):
        raise ValueError(f"colors must have shape {shape_prefix + (3,)} or (…, 4), got {arr.shape}")
    if np.any(arr < 0.0) or np.any(arr > 1.0) or not np.all(np.isfinite(arr)):
        raise ValueError("colors must lie in [0, 1]")
    return arr


#: the ``KHR_materials_variants`` variant holding the texture when vertex colours lead
TEXTURE_VARIANT = "key 0 texture"


def _add_material(b: GlbBuilder, texture_png: bytes | None, as_variant: bool = False) -> int:
    """The primitive's material: textured (``texture_png``) or plain. With ``as_variant``
    the default material is plain (vertex colours show unmultiplied) and the textured one
    is the ``KHR_materials_variants`` variant :data:`TEXTURE_VARIANT` (material 1)."""
    if as_variant and texture_png is not None:
        _add_material(b, None)
        _add_material(b, texture_png)
        b.gltf.materials[1].name = "texture"
        b.gltf.extensions = {"KHR_materials_variants": {"variants": [{"name": TEXTURE_VARIANT}]}}
        b.gltf.extensionsUsed = [*(b.gltf.extensionsUsed or []), "KHR_materials_variants"]
        return 0
    pbr = g.PbrMetallicRoughness(
        baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=1.0
    )
    if texture_png is not None:
        if not texture_png.startswith(b"\x89PNG\r\n\x1a\n"):
            raise ValueError("texture_png must be the bytes of a PNG file")
        b.gltf.images.append(g.Image(bufferView=b.view(texture_png), mimeType="image/png"))
        b.gltf.samplers.append(
            g.Sampler(
                magFilter=g.LINEAR,
                minFilter=g.LINEAR_MIPMAP_LINEAR,
                wrapS=g.CLAMP_TO_EDGE,
                wrapT=g.CLAMP_TO_EDGE,
            )
        )
        b.gltf.textures.append(g.Texture(sampler=0, source=0))
        pbr.baseColorTexture = g.TextureInfo(index=0)
    b.gltf.materials.append(g.Material(pbrMetallicRoughness=pbr, doubleSided=True, name="surface"))
    return len(b.gltf.materials) - 1


def _base_primitive(
    b: GlbBuilder,
    V: NDArray[np.float64],
    F: NDArray[np.uint32],
    *,
    normals: NDArray[np.float64] | None,
    colors: NDArray[np.float64] | None,
    uv: ArrayLike | None,
    texture_png: bytes | None,
    texture_variant: bool = False,
    grid: PositionGrid | None = None,
) -> g.Primitive:
    """The base mesh's primitive; with ``grid`` (a compressed morph) positions in the
    grid's units (float, nearly exact), normals octahedral, colours 16-bit integers."""
    n = V.shape[0]
    if grid is None:
        pos, tol = V, position_tolerance(V)
    else:
        pos, tol = (V - grid.offset) / grid.scale, grid.base_tolerance / grid.scale
    attrs = g.Attributes(POSITION=b.accessor(pos, g.VEC3, minmax=True, tolerance=tol))
    if normals is not None:
        if grid is None:
            attrs.NORMAL = b.accessor(normals, g.VEC3, tolerance=NORMAL_TOLERANCE)
        else:
            attrs.NORMAL = b.unit_vector_accessor(normals)
    if colors is not None:
        ty = g.VEC3 if colors.shape[1] == 3 else g.VEC4
        if grid is None:
            attrs.COLOR_0 = b.accessor(colors, ty, tolerance=COLOR_TOLERANCE)
        else:
            attrs.COLOR_0 = b.int_accessor(unorm16_rows(colors), ty)
    if uv is not None:
        uv_arr = np.asarray(uv, dtype=np.float64)
        if uv_arr.shape != (n, 2) or not np.all(np.isfinite(uv_arr)):
            raise ValueError(f"uv must have shape ({n}, 2) and be finite, got {uv_arr.shape}")
        attrs.TEXCOORD_0 = b.accessor(uv_arr, g.VEC2, tolerance=UV_TOLERANCE)
    elif texture_png is not None:
        raise ValueError("texture_png needs uv")
    indices = b.accessor(F.reshape(-1), g.SCALAR, target=g.ELEMENT_ARRAY_BUFFER, minmax=False)
    variant = texture_variant and texture_png is not None and colors is not None
    prim = g.Primitive(
        attributes=attrs,
        indices=indices,
        material=_add_material(b, texture_png, as_variant=variant),
        mode=g.TRIANGLES,
    )
    if variant:
        prim.extensions = {
            "KHR_materials_variants": {"mappings": [{"material": 1, "variants": [0]}]}
        }
    return prim


def write_frame_glb(
    path: str | Path,
    V: ArrayLike,
    F: ArrayLike,
    *,
    normals: bool = True,
    colors: ArrayLike | None = None,
    uv: ArrayLike | None = None,
    texture_png: bytes | None = None,
    name: str = "frame",
    extras: dict[str, Any] | None = None,
    compress: str = "none",
) -> dict[str, Any]:
    """Write one static triangle mesh as a GLB file.

    Parameters
    ----------
    path : str or Path
        Output file (parent folders are created; written atomically).
    V : (n, 3) or (n, 2) float64
        Vertex positions; 2D positions are placed at z = 0.
    F : (m, 3) int
        Triangles (counter-clockwise seen from +z for 2D meshes).
    normals : bool, optional
        Write smooth unit vertex normals (:func:`unit_vertex_normals`).
        Default True: without them viewers must shade faces flat.
    colors : (n, 3) or (n, 4) float64, optional
        Vertex colours in [0, 1] (linear RGB[A]).
    uv : (n, 2) float64, optional
        Texture coordinates in glTF's convention (origin at the image's top
        left corner).
    texture_png : bytes, optional
        A PNG image used as the base-colour texture (needs ``uv``).
    name : str, optional
        Mesh and node name.
    extras : dict, optional
        JSON-able application data stored on the node and the mesh (``extras``).
    compress : {"none", "auto", "meshopt"}
        ``EXT_meshopt_compression`` (:mod:`conformorph.pipelines.gltf_compression`);
        default none.

    Returns
    -------
    dict
        ``{"bytes": file size, "vertices": n, "faces": m, "targets": 0}``.
    """
    Vp = _as_positions(V, "V")
    Fu = _as_faces(F, Vp.shape[0])
    b = GlbBuilder()
    N = unit_vertex_normals(Vp, Fu.astype(np.int64)) if normals else None
    C = _as_colors(colors, (Vp.shape[0],)) if colors is not None else None
    prim = _base_primitive(b, Vp, Fu, normals=N, colors=C, uv=uv, texture_png=texture_png)
    b.gltf.meshes.append(g.Mesh(primitives=[prim], name=name, extras=dict(extras or {})))
    b.gltf.nodes.append(g.Node(mesh=0, name=name, extras=dict(extras or {})))
    b.gltf.scenes.append(g.Scene(nodes=[0]))
    b.gltf.scene = 0
    size = b.save(path, compress)
    return {"bytes": size, "vertices": int(Vp.shape[0]), "faces": int(Fu.shape[0]), "targets": 0}


@dataclass(frozen=True)
class MorphAppearance:
    """Appearance of a morph GLB (:func:`write_morph_glb`).

    Attributes
    ----------
    normals : bool
        Write a ``NORMAL`` delta per morph target (the normals of frame k minus
        the base's) when the morph changes the normals (some unit normal moves by
        more than :data:`~conformorph.pipelines.glb_normals.NORMAL_CHANGE_TOL`). Default True: with static normals
        three.js and Babylon light an opened mouth as if it were closed. The base
        normals are always written. Blender ignores normal targets (it recomputes
        normals from the morphed positions), and each one takes one of the 8
        morphed attributes viewers guarantee (4 targets with normals; at most two
        targets are active at once here).
    colors : (n, 3|4) or (T, n, 3|4) float64, optional
        Static vertex colours, or per-frame colours whose deltas to frame 0
        ride on ``COLOR_0`` morph targets (base colour = ``colors[0]``).
    uv : (n, 2) float64, optional
        Static texture coordinates (glTF convention, origin top left).
    texture_png : bytes, optional
        PNG base-colour texture (needs ``uv``).
    texture_variant : bool
        With both ``colors`` and ``texture_png``: the default material is plain, so the
        (morphing) vertex colours show as they are (glTF multiplies ``COLOR_0`` into the
        base colour, a texture included), and the textured material is the
        ``KHR_materials_variants`` variant :data:`TEXTURE_VARIANT`. Default False.
    """

    normals: bool = True
    colors: ArrayLike | None = None
    uv: ArrayLike | None = None
    texture_png: bytes | None = None
    texture_variant: bool = False


@dataclass(frozen=True)
class MorphOutput:
    """What a morph GLB says about itself, and how it is stored (:func:`write_morph_glb`).

    Attributes
    ----------
    target_names : sequence of str, optional
        One name per target, in ``mesh.extras.targetNames`` (the Blender and three.js
        convention); default ``frame_000``, ….
    extras : dict, optional
        JSON-able application data stored on the node and the mesh (the mesh's also
        gets ``targetNames``).
    compress : {"none", "auto", "meshopt"}
        ``EXT_meshopt_compression`` (:mod:`conformorph.pipelines.gltf_compression`):
        never (default here), above ``AUTO_MIN_BYTES``, or always. A compressed morph
        GLB (not sparse) stores its targets quantized (``KHR_mesh_quantization``,
        :mod:`conformorph.pipelines.gltf_quantization`), its mesh on a child of node 0
        that dequantizes; ``none`` keeps plain float32 and node 0 holding the mesh.
    """

    target_names: Sequence[str] | None = None
    extras: dict[str, Any] | None = None
    compress: str = "none"


def _checked_frames(
    frames_V: ArrayLike, times: ArrayLike, n: int, target_names: Sequence[str] | None
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[str]]:
    """Frames (T, n, 3) (2D → z = 0), times (T,) and target names, checked."""
    fr = np.asarray(frames_V, dtype=np.float64)
    if fr.ndim == 3 and fr.shape[2] == 2:
        fr = np.concatenate([fr, np.zeros(fr.shape[:2] + (1,))], axis=2)
    if fr.ndim != 3 or fr.shape[1:] != (n, 3) or fr.shape[0] == 0:
        raise ValueError(f"frames_V must have shape (T, {n}, 3), got {np.shape(frames_V)}")
    if not np.all(np.isfinite(fr)):
        raise ValueError("frames_V has non-finite coordinates")
    T = fr.shape[0]
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if t.shape != (T,):
        raise ValueError(f"times must have shape ({T},), got {t.shape}")
    if not np.all(np.isfinite(t)) or t[0] < 0 or np.any(np.diff(t) <= 0):
        raise ValueError("times must be finite, non-negative and strictly increasing")
    names = list(target_names) if target_names is not None else [f"frame_{k:03d}" for k in range(T)]
    if len(names) != T:
        raise ValueError(f"target_names has {len(names)} names for {T} frames")
    return fr, t, names


def _checked_rigid(
    rigid: tuple[ArrayLike, ...], T: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
    """``(translation (T, 3), unit quaternions (T, 4), scale (T, 3) or None)``, checked."""
    if len(rigid) not in (2, 3):
        raise ValueError("rigid must be (translation, rotation) or (translation, rotation, scale)")
    tr, rot = (np.asarray(a, dtype=np.float64) for a in rigid[:2])
    sc = None if len(rigid) == 2 or rigid[2] is None else np.asarray(rigid[2], dtype=np.float64)
    if tr.shape != (T, 3) or rot.shape != (T, 4) or (sc is not None and sc.shape != (T, 3)):
        raise ValueError(
            f"rigid must be (translation ({T}, 3), rotation ({T}, 4)[, scale ({T}, 3)]), "
            f"got {tr.shape}, {rot.shape}, {None if sc is None else sc.shape}"
        )
    if not (np.all(np.isfinite(tr)) and np.all(np.isfinite(rot))) or (
        sc is not None and not np.all(np.isfinite(sc))
    ):
        raise ValueError("rigid motion has non-finite values")
    if np.any(np.abs(np.linalg.norm(rot, axis=1) - 1.0) > 1e-6):
        raise ValueError("rotation quaternions must have unit length")
    return tr, rot / np.linalg.norm(rot, axis=1, keepdims=True), sc


_IDENTITY = {g.TRANSLATION: [0.0, 0.0, 0.0], g.ROTATION: [0.0, 0.0, 0.0, 1.0], g.SCALE: [1.0] * 3}


def _animation_channels(
    b: GlbBuilder, node: Any, t: NDArray[np.float64], rigid: Any, name: str, mesh_node: int = 0
) -> None:
    """The weights animation (one-hot keys, LINEAR) on ``mesh_node`` and the rigid TRS
    channels on node 0 (``node``)."""
    T = t.size
    t32 = t.astype(np.float32)
    if T > 1 and np.any(np.diff(t32) <= 0):
        raise ValueError("times are too close together to stay strictly increasing in float32")
    t_acc = b.accessor(t32, g.SCALAR, target=None, minmax=True)
    samplers = []
    channels = []
    if T > 1:
        w_acc = b.accessor(np.eye(T, dtype=np.float32).reshape(-1), g.SCALAR, target=None)
        samplers.append(g.AnimationSampler(input=t_acc, output=w_acc, interpolation=g.ANIM_LINEAR))
        channels.append(
            g.AnimationChannel(
                sampler=0, target=g.AnimationChannelTarget(node=mesh_node, path=g.WEIGHTS)
            )
        )
    if rigid is not None:
        tr, rot, sc = _checked_rigid(rigid, T)
        channels_in = [(tr, g.VEC3, g.TRANSLATION), (rot, g.VEC4, g.ROTATION)]
        if sc is not None:
            channels_in.append((sc, g.VEC3, g.SCALE))
        for arr, ty, p in channels_in:
            rest = [float(x) for x in arr[0]]
            if rest != _IDENTITY[p]:  # the node's rest transform: frame 0's, identity omitted
                setattr(node, p, rest)
            out = b.accessor(arr, ty, target=None)
            samplers.append(
                g.AnimationSampler(input=t_acc, output=out, interpolation=g.ANIM_LINEAR)
            )
            channels.append(
                g.AnimationChannel(
                    sampler=len(samplers) - 1, target=g.AnimationChannelTarget(node=0, path=p)
                )
            )
    if samplers:
        b.gltf.animations.append(g.Animation(samplers=samplers, channels=channels, name=name))
    else:  # a single frame and no rigid motion: nothing animates, drop the unused accessor
        b.gltf.accessors.pop()
        b.gltf.bufferViews.pop()


def write_morph_glb(
    path: str | Path,
    base_V: ArrayLike,
    F: ArrayLike,
    frames_V: ArrayLike,
    times: ArrayLike,
    *,
    appearance: MorphAppearance = MorphAppearance(),
    rigid: tuple[ArrayLike, ...] | None = None,
    sparse: bool = False,
    name: str = "morph",
    output: MorphOutput | None = None,
) -> dict[str, Any]:
    """Write a morph sequence as ONE animated GLB (morph targets + weights animation).

    Parameters
    ----------
    path : str or Path
        Output file (parent folders are created; written atomically).
    base_V : (n, 3) or (n, 2) float64
        Base mesh positions (usually the first frame); 2D → z = 0.
    F : (m, 3) int
        Triangles shared by all frames.
    frames_V : (T, n, 3) or (T, n, 2) float64
        Positions of every frame; frame k becomes morph target k with
        position deltas ``frames_V[k] − base_V``.
    times : (T,) float64
        Key time of each frame in seconds, strictly increasing, ≥ 0.
    appearance : MorphAppearance, optional
        Normal targets, vertex colours, texture coordinates and texture (the
        base mesh's smooth normals are always written).
    rigid : tuple of arrays, optional
        ``(translation (T, 3), rotation (T, 4) unit quaternions x, y, z, w[,
        scale (T, 3)])``, keyed at ``times`` on the node's TRS channels (no scale
        channel without ``scale``); the node's rest transform is frame 0's, and an
        identity part of it is left out of the node.
    sparse : bool, optional
        Store targets as sparse accessors (only vertices that move).
    name : str, optional
        Mesh, node and animation name.
    output : MorphOutput, optional
        Target names (default ``frame_000``, …), ``extras`` of the node and mesh,
        compression (default none).

    Returns
    -------
    dict
        ``{"bytes", "vertices", "faces", "targets", "sparse", "normal_targets",
        "quantization"}``; ``quantization`` is None for a float file, else
        ``{"position_step", "position_error_bound"}`` (model units: the delta grid's step
        and the largest distance of a decoded vertex from the float file's, see
        :mod:`conformorph.pipelines.gltf_quantization`).

    Raises
    ------
    ValueError
        Wrong shapes, non-finite data, non-increasing times, colours outside
        [0, 1], non-unit quaternions.

    Notes
    -----
    Weights: key k is the one-hot vector e_k and the sampler is LINEAR, so
    between keys k and k+1 exactly targets k and k+1 are active with weights
    summing to 1 and the shape moves linearly between the two frames. The
    weight data grows as T² floats (~40 KB at T = 100).
    """
    Vb = _as_positions(base_V, "base_V")
    n = Vb.shape[0]
    Fu = _as_faces(F, n)
    output = MorphOutput() if output is None else output
    extras = output.extras
    fr, t, names = _checked_frames(frames_V, times, n, output.target_names)
    T = fr.shape[0]
    base_C: NDArray[np.float64] | None = None
    frame_C: NDArray[np.float64] | None = None
    if appearance.colors is not None:
        c = np.asarray(appearance.colors, dtype=np.float64)
        if c.ndim == 3:
            frame_C = _as_colors(c, (T, n))
            base_C = frame_C[0]
        else:
            base_C = _as_colors(c, (n,))
    Fi = Fu.astype(np.int64)
    base_N = unit_vertex_normals(Vb, Fi)
    frame_N = changed_normals(fr, Fi, base_N) if appearance.normals else None
    data = TargetData(fr, Vb, frame_N, base_N, frame_C, base_C)
    doc = _MorphDocument(Fu, t, names, appearance, rigid, sparse, name, dict(extras or {}))
    # float unless compressed (auto: the float file's size decides, from its arrays: the
    # float file is then built only when it is written)
    grid = None
    if not sparse and compresses(output.compress, _float_buffer_bytes(doc, data)):
        data = rebased(data, central_frame(fr))
        grid = position_grid(data.base_V, fr)
    b = _built(doc, data, grid)
    size = b.save(path, "meshopt" if grid is not None else output.compress)
    return {
        "bytes": size,
        "vertices": n,
        "faces": int(Fu.shape[0]),
        "targets": T,
        "sparse": sparse,
        "normal_targets": frame_N is not None,
        "quantization": None
        if grid is None
        else {
            "position_step": float(grid.step),
            "position_error_bound": float(grid.error_bound),
        },
    }


@dataclass(frozen=True)
class _MorphDocument:
    """The parts of a morph GLB other than its vertex data."""

    F: NDArray[np.uint32]
    times: NDArray[np.float64]
    names: list[str]
    appearance: MorphAppearance
    rigid: tuple[ArrayLike, ...] | None
    sparse: bool
    name: str
    extras: dict[str, Any]


def _float_buffer_bytes(doc: _MorphDocument, data: TargetData) -> int:
    """The binary buffer of the uncompressed (float32, dense) morph GLB, from its arrays:
    base positions, normals, colours, texture coordinates, triangles and texture, and
    every target's positions, normals and colours. The whole file adds its JSON and the
    weights animation (a few KB): what ``--compress auto`` compares with its threshold."""
    n, T = data.base_V.shape[0], data.frames_V.shape[0]
    per_vertex = 3 + 3 + (0 if data.base_C is None else data.base_C.shape[1])
    per_vertex += 0 if doc.appearance.uv is None else 2
    per_target = 3 + (0 if data.frame_N is None else 3)
    per_target += 0 if data.frame_C is None else data.frame_C.shape[2]
    png = 0 if doc.appearance.texture_png is None else len(doc.appearance.texture_png)
    return 4 * n * (per_vertex + T * per_target) + 4 * int(doc.F.size) + png


def _built(doc: _MorphDocument, data: TargetData, grid: PositionGrid | None) -> GlbBuilder:
    """The morph GLB's document and buffer: float, or quantized on ``grid``."""
    b = GlbBuilder()
    prim = _base_primitive(
        b,
        data.base_V,
        doc.F,
        normals=data.base_N,
        colors=data.base_C,
        uv=doc.appearance.uv,
        texture_png=doc.appearance.texture_png,
        texture_variant=doc.appearance.texture_variant,
        grid=grid,
    )
    if grid is None:
        prim.targets = float_morph_targets(b, data, doc.sparse)
    else:
        prim.targets = quantized_morph_targets(b, data, grid)
    T = data.frames_V.shape[0]
    b.gltf.meshes.append(
        g.Mesh(
            primitives=[prim],
            weights=[1.0 if k == 0 else 0.0 for k in range(T)],
            name=doc.name,
            extras={**doc.extras, "targetNames": doc.names},
        )
    )
    mesh_node = dequantization_nodes(b, doc.name, doc.extras, grid)
    b.gltf.scenes.append(g.Scene(nodes=[0]))
    b.gltf.scene = 0
    _animation_channels(b, b.gltf.nodes[0], doc.times, doc.rigid, doc.name, mesh_node)
    return b
