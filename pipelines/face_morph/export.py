"""Stage 4 of the face morph: ``animation.glb`` (morph targets, weights animation, rigid
TRS), optional ``frames/NNN.glb`` and ``textures/key_NNN.png``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

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


def export_outputs(
    reg: Arrays, frames: Arrays, outdir: str | Path, options: ExportOptions | None = None
) -> dict[str, Any]:
    """Stage 4: write ``animation.glb`` (and ``frames/NNN.glb`` with ``per_frame``).

    The base mesh is frame 0 in the aligned frame; each frame is a morph
    target; the interpolated similarity rides on the node's TRS channels.

    Parameters
    ----------
    reg : stage-2 dict
    frames : stage-3 dict
    outdir : path
        Output folder (created).
    options : ExportOptions, optional (default ``ExportOptions()``)
        Per-frame files, sparse targets, NORMAL targets. Every GLB carries
        its base mesh's smooth vertex normals whatever the options.

    Returns
    -------
    dict
        File name → size in bytes.

    Notes
    -----
    Appearance. Vertex colours (when every input has them) ride on
    ``COLOR_0`` with one colour delta per morph target, so they cross-fade
    with the shape (three.js and Babylon morph colours; Blender imports
    positions only). Textures (when every input has UVs and an image): each
    key's texture is rendered on one atlas layout over the consistent mesh
    (the first input's UVs, ``TEXCOORD_0``); frame k's texture is the spline
    blend of the key textures. Core glTF cannot animate a texture, so
    ``animation.glb`` carries frame 0's texture (static) and no ``COLOR_0``
    (which would multiply it); every ``frames/NNN.glb`` carries its own
    blended texture (the cross-fade), and ``textures/key_NNN.png`` are the
    key textures on the shared layout, for viewers that blend textures
    themselves.
    """
    options = ExportOptions() if options is None else options
    from conformorph.geometry.rotation_interpolation import rotation_to_quaternion_xyzw
    from conformorph.pipelines.export_gltf import MorphAppearance, write_frame_glb, write_morph_glb

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    F = reg["cm_F"]
    Va = frames["frames_aligned"]
    te = frames["frame_times"]
    colors = frames.get("frames_colors")
    files: dict[str, Any] = {}
    uv = None
    textures = reg.get("key_textures")
    if textures is not None and frames.get("frame_texture_weights") is not None:
        colors = None
        uv = np.c_[reg["cm_tex_uv"][:, 0], 1.0 - reg["cm_tex_uv"][:, 1]]  # glTF: origin top left
        (out / "textures").mkdir(exist_ok=True)
        for i in range(textures.shape[0]):
            name = f"textures/key_{i:03d}.png"
            (out / name).write_bytes(png_bytes(textures[i]))
            files[name] = (out / name).stat().st_size
    q = rotation_to_quaternion_xyzw(frames["frame_R"])
    s = np.repeat(frames["frame_s"][:, None], 3, axis=1)
    info = write_morph_glb(
        out / "animation.glb",
        Va[0],
        F,
        Va,
        te - te[0],
        appearance=MorphAppearance(
            normals=options.normals,
            colors=colors,
            uv=uv,
            texture_png=frame_texture_png(reg, frames, 0),
        ),
        rigid=(frames["frame_t"], q, s),
        sparse=options.sparse,
        name="face_morph",
        target_names=[f"t={t:.4g}" for t in te],
    )
    files["animation.glb"] = int(info.get("bytes", 0))
    if options.per_frame:
        (out / "frames").mkdir(exist_ok=True)
        for k in range(te.size):
            p = out / "frames" / f"{k:03d}.glb"
            write_frame_glb(
                p,
                frames["frames_V"][k],
                F,
                colors=None if colors is None else colors[k],
                uv=uv,
                texture_png=frame_texture_png(reg, frames, k),
            )
            files[f"frames/{k:03d}.glb"] = p.stat().st_size
    return files
