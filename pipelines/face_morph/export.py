"""Stage 4 of the face morph: ``animation.glb`` (morph targets, weights animation, rigid
motion on the node), optional ``frames/NNN.glb`` and ``textures/key_NNN.png``, in metres."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays, ExportOptions
from conformorph.pipelines.face_morph.textures import png_bytes


def frame_texture_png(reg: Arrays, frames: Arrays, k: int) -> bytes | None:
    """PNG of frame k's texture, ``Σ_i w[k, i] key_textures[i]`` (None without textures)."""
    textures = reg.get("key_textures")
    weights = frames.get("frame_texture_weights")
    if textures is None or weights is None:
        return None
    blend = np.einsum("i,ihwc->hwc", weights[k], textures.astype(np.float64))
    return png_bytes(np.clip(np.rint(blend), 0, 255).astype(np.uint8))


@dataclass(frozen=True)
class SceneInfo:
    """What the export writes beside the frames: units and names.

    Attributes
    ----------
    metres_per_unit : float
        Length of the working unit (key 0's, :mod:`conformorph.pipelines.face_morph.units`)
        in metres; every GLB is written in metres. Default 1.
    key_names : tuple of str
        The keys' names (their file stems), for node, mesh and target names and
        ``extras``. Default: ``key0``, ``key1``, …
    key_times : tuple of float
        The keys' times, to name the frames that fall on a key. Default: none.
    """

    metres_per_unit: float = 1.0
    key_names: tuple[str, ...] = ()
    key_times: tuple[float, ...] = ()

    def names(self, n_keys: int) -> list[str]:
        """The key names, ``key{i}`` where none were given."""
        got = list(self.key_names)
        return got + [f"key{i}" for i in range(len(got), n_keys)]

    def key_at(self, t: float) -> str | None:
        """The name of the key at time ``t`` (to 1e-9 of the key span), or None."""
        kt = np.asarray(self.key_times, dtype=np.float64)
        if kt.size == 0:
            return None
        tol = 1e-9 * max(float(kt[-1] - kt[0]), 1.0)
        hit = np.flatnonzero(np.abs(kt - t) <= tol)
        return self.names(kt.size)[int(hit[0])] if hit.size else None


def srgb_to_linear(c: NDArray[np.float64]) -> NDArray[np.float64]:
    """sRGB-encoded values in [0, 1] to linear ones (the sRGB transfer function, IEC 61966-2-1)."""
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def texture_vertex_colors(reg: Arrays, frames: Arrays) -> NDArray[np.float64] | None:
    """(T, n, 3) linear vertex colours of every frame baked from the key textures.

    Each key texture is sampled bilinearly at the consistent mesh's UVs (``cm_tex_uv``,
    OBJ convention: texel centres at ((j + ½)/w, 1 − (i + ½)/h)); frame k's colour is
    ``Σ_i w[k, i] · sample_i`` (the spline weights of ``frame_texture_weights``, the
    same blend as frame k's texture), clipped to [0, 255], and converted from the
    texture's sRGB encoding to the linear values ``COLOR_0`` holds, so that a viewer
    shows at every vertex the colour the frame's texture has there. None without
    textures.
    """
    textures = reg.get("key_textures")
    weights = frames.get("frame_texture_weights")
    if textures is None or weights is None:
        return None
    uv = np.asarray(reg["cm_tex_uv"], dtype=np.float64)
    K, h, w = textures.shape[:3]
    x = np.clip(uv[:, 0] * w - 0.5, 0.0, w - 1.0)
    y = np.clip((1.0 - uv[:, 1]) * h - 0.5, 0.0, h - 1.0)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 2 if w > 1 else 0)
    y0 = np.minimum(np.floor(y).astype(np.int64), h - 2 if h > 1 else 0)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    samples = np.zeros((K, uv.shape[0], 3))
    for i in range(K):
        t = textures[i][..., :3].astype(np.float64)
        top = t[y0, x0] * (1 - fx) + t[y0, x1] * fx
        bottom = t[y1, x0] * (1 - fx) + t[y1, x1] * fx
        samples[i] = top * (1 - fy) + bottom * fy
    blended = np.einsum("ki,inc->knc", np.asarray(weights, dtype=np.float64), samples)
    return srgb_to_linear(np.clip(blended, 0.0, 255.0) / 255.0)


def rest_pose_rig(
    frames: Arrays, metres_per_unit: float
) -> tuple[NDArray[np.float64], tuple[NDArray[np.float64], NDArray[np.float64]] | None]:
    """Frame positions for morph targets and the node motion that places them.

    Frame k of the homotopy is ``x_k = s_k R_k Va_k + t_k`` (``frames_V``; Va the shape at
    unit diameter, the interpolated similarity's scale s_k, rotation R_k, translation
    t_k). The mesh is stored at its real size in frame 0's place, in metres (m = metres
    per unit): ``Q_k = m (s_k R_0 Va_k + t_0) = m (R_0 R_kᵀ (x_k − t_k) + t_0)``, so frame
    0 needs no node transform (the rest transform is the identity) and the node's motion
    at frame k is the rigid ``x ↦ R_k R_0ᵀ x + m (t_k − R_k R_0ᵀ t_0)``, which takes Q_k
    to ``m · frames_V[k]`` exactly. Q_k is formed from ``frames_V`` (one 3x3 product and
    one shift a frame), so a full-resolution output needs no shape-space copy of its
    frames. The similarity's scale rides on the shape (the targets), never on the node:
    keys of one size keep s_k within a few per cent of s_0 and an animated node scale
    would be a needless keyframed channel for an animator; keys of different sizes
    morph their size with their shape, exactly at every frame, and between two frames
    the shape moves linearly (as it does for every other part of the deformation).

    Parameters
    ----------
    frames : stage-3 dict
        ``frames_V (T, n, 3)``, ``frame_R (T, 3, 3)``, ``frame_t (T, 3)``.
    metres_per_unit : float

    Returns
    -------
    Q : (T, n, 3) float64
        Mesh positions of every frame, metres.
    rigid : ((T, 3) translation, (T, 4) unit quaternions x, y, z, w) or None
        The node's motion; None when it never moves (all frames at frame 0's place).
    """
    from conformorph.geometry.rotation_interpolation import rotation_to_quaternion_xyzw
    from conformorph.geometry.threads import map_in_threads

    m = float(metres_per_unit)
    X = np.asarray(frames["frames_V"], dtype=np.float64)
    R = np.asarray(frames["frame_R"], dtype=np.float64)
    t = np.asarray(frames["frame_t"], dtype=np.float64)
    Rrel = R @ R[0].T  # (T, 3, 3)
    M = m * Rrel  # rows: Q_k = x_k M_k + c_k, M_k = m R_k R_0ᵀ = (m R_0 R_kᵀ)ᵀ
    c = m * t[0] - np.einsum("kj,kji->ki", t, M)
    Q = np.zeros_like(X)

    def place(k: int) -> None:  # in place, frames on threads
        np.matmul(X[k], M[k], out=Q[k])
        Q[k] += c[k]

    map_in_threads(place, list(range(X.shape[0])))
    trans = m * (t - np.einsum("kij,j->ki", Rrel, t[0]))
    scale = max(float(np.abs(Q[0]).max()), 1e-300)
    still = np.allclose(Rrel, np.eye(3), atol=1e-12) and np.all(np.abs(trans) <= 1e-12 * scale)
    if still:
        return Q, None
    return Q, (trans, rotation_to_quaternion_xyzw(Rrel))


def _frame_names(te: NDArray[np.float64], scene: SceneInfo) -> list[str]:
    """``t=0.5`` for every frame, ``t=1 smile`` for a frame on key ``smile``."""
    out = []
    for t in te:
        key = scene.key_at(float(t))
        out.append(f"t={t:.4g}" + ("" if key is None else f" {key}"))
    return out


def export_outputs(
    reg: Arrays,
    frames: Arrays,
    outdir: str | Path,
    options: ExportOptions | None = None,
    *,
    scene: SceneInfo | None = None,
) -> dict[str, Any]:
    """Stage 4: write ``animation.glb`` (and ``frames/NNN.glb`` with ``per_frame``), in metres.

    The mesh is stored at its real size in frame 0's place (:func:`rest_pose_rig`):
    the node's rest transform is the identity, each frame's shape (its size included)
    is a morph target, and the interpolated rigid motion rides on the node's
    translation and rotation channels.

    Parameters
    ----------
    reg : stage-2 dict
    frames : stage-3 dict
    outdir : path
        Output folder (created).
    options : ExportOptions, optional (default ``ExportOptions()``)
        Per-frame files, sparse targets, NORMAL targets.
    scene : SceneInfo, optional
        Units (metres per working unit) and the keys' names and times.

    Returns
    -------
    dict
        File name → size in bytes.

    Notes
    -----
    Naming. The node and mesh of ``animation.glb`` are named after the first and last
    key (``neutral_to_jawOpen``), its targets after their time and the key they fall
    on (``t=1 smile``), and ``extras`` hold every key's name and time and the units;
    ``frames/NNN.glb`` name node and mesh ``frame_NNN`` (plus the key's name on a key).

    Lighting. Normal targets (``options.normals``, the default) are written when
    the morph changes the normals (:func:`conformorph.pipelines.export_gltf.write_morph_glb`);
    three.js and Babylon morph them, Blender ignores them (it recomputes normals from
    the morphed positions itself).

    Appearance. Vertex colours (when every input has them) ride on
    ``COLOR_0`` with one colour delta per morph target, so they cross-fade
    with the shape (three.js and Babylon morph colours; Blender imports
    positions only). Textures (when every input has UVs and an image): each
    key's texture is rendered on one atlas layout over the consistent mesh
    (the first input's UVs, ``TEXCOORD_0``); frame k's texture is the spline
    blend of the key textures. Core glTF cannot animate a texture, so
    ``animation.glb`` carries the cross-fade as ``COLOR_0`` morph targets baked
    from the frame textures at the vertices (:func:`texture_vertex_colors`; its
    default material is untextured, since glTF multiplies ``COLOR_0`` into the
    texture), and key 0's texture with ``TEXCOORD_0`` as the
    ``KHR_materials_variants`` variant "key 0 texture" (the fallback with full
    texture detail, static). Every ``frames/NNN.glb`` carries its own blended
    texture (the cross-fade at texture resolution), and
    ``textures/key_NNN.png`` are the key textures on the shared layout, for
    viewers that blend textures themselves.
    """
    options = ExportOptions() if options is None else options
    scene = SceneInfo() if scene is None else scene
    from conformorph.pipelines.export_gltf import MorphAppearance, MorphOutput, write_morph_glb

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    F = reg["cm_F"]
    te = np.asarray(frames["frame_times"], dtype=np.float64)
    colors = frames.get("frames_colors")
    files: dict[str, Any] = {}
    uv = None
    baked = texture_vertex_colors(reg, frames)  # None without textures
    textures = reg.get("key_textures")
    if textures is not None and frames.get("frame_texture_weights") is not None:
        colors = None
        uv = np.c_[reg["cm_tex_uv"][:, 0], 1.0 - reg["cm_tex_uv"][:, 1]]  # glTF: origin top left
        (out / "textures").mkdir(exist_ok=True)
        for i in range(textures.shape[0]):
            name = f"textures/key_{i:03d}.png"
            (out / name).write_bytes(png_bytes(textures[i]))
            files[name] = (out / name).stat().st_size
    n_keys = max(len(scene.key_names), len(scene.key_times), 2)
    keys = scene.names(n_keys)
    extras = {
        "keys": keys,
        "key_times": list(scene.key_times),
        "units": "m",
        "metres_per_input_unit": scene.metres_per_unit,
    }
    Q, rigid = rest_pose_rig(frames, scene.metres_per_unit)
    name = f"{keys[0]}_to_{keys[-1]}"
    info = write_morph_glb(
        out / "animation.glb",
        Q[0],
        F,
        Q,
        te - te[0],
        appearance=MorphAppearance(
            normals=options.normals,
            colors=colors if baked is None else baked,
            uv=uv,
            texture_png=frame_texture_png(reg, frames, 0),
            texture_variant=baked is not None,
        ),
        rigid=rigid,
        sparse=options.sparse,
        name=name,
        output=MorphOutput(
            target_names=_frame_names(te, scene), extras=extras, compress=options.compress
        ),
    )
    files["animation.glb"] = int(info.get("bytes", 0))
    if options.per_frame:
        _write_frames(out, frames, F, scene, (colors, uv, keys, options.compress), files, reg)
    return files


def _write_frames(
    out: Path,
    frames: Arrays,
    F: Any,
    scene: SceneInfo,
    appearance: tuple[Any, Any, Sequence[str], str],
    files: dict[str, Any],
    reg: Arrays,
) -> None:
    """``frames/NNN.glb``: frame k placed (its rigid motion applied), metres, named."""
    from conformorph.pipelines.export_gltf import write_frame_glb

    colors, uv, keys, compress = appearance
    te = np.asarray(frames["frame_times"], dtype=np.float64)
    (out / "frames").mkdir(exist_ok=True)
    for k in range(te.size):
        p = out / "frames" / f"{k:03d}.glb"
        key = scene.key_at(float(te[k]))
        write_frame_glb(
            p,
            scene.metres_per_unit * np.asarray(frames["frames_V"][k], dtype=np.float64),
            F,
            colors=None if colors is None else colors[k],
            uv=uv,
            texture_png=frame_texture_png(reg, frames, k),
            name=f"frame_{k:03d}" + ("" if key is None else f"_{key}"),
            extras={"frame": k, "t": float(te[k]), "key": key, "keys": list(keys), "units": "m"},
            compress=compress,
        )
        files[f"frames/{k:03d}.glb"] = p.stat().st_size
