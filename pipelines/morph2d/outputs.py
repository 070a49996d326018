"""Outputs of the 2D morph: ``animation.glb``, ``frames/NNN.glb``, ``strip.svg``,
``animation.svg``, ``frames.json``, ``metrics.json``.

* ``animation.glb``: the frames, 2D meshes at z = 0 as morph targets with a
  one-hot LINEAR ``weights`` animation (see :mod:`conformorph.pipelines.export_gltf`), with
  the texture, when given, carried by static UVs;
* ``frames/000.glb`` … when ``per_frame``;
* ``strip.svg``: a strip of frames; ``strip.png`` the same as a picture
  (:mod:`conformorph.pipelines.morph2d.strip_png`);
* ``animation.svg`` and ``frames.json``: the web outputs of
  :mod:`conformorph.pipelines.animation_svg` (each part's boundary loops of every frame,
  grouped into parts by :func:`conformorph.pipelines.morph2d.frame_parts.frame_parts`,
  played evenly at ``FPS`` like ``animation.glb``, looping as ``loop`` says);
  ``frames.json``'s ``outline`` and ``holes`` are the first (largest) part's, and
  ``parts`` lists every part's;
* ``animation.json``: the same frames as a Lottie animation
  (:mod:`conformorph.pipelines.animation_lottie`), one shape layer per part;
* ``metrics.json``: the metrics (:mod:`conformorph.pipelines.morph2d.metrics`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from conformorph.geometry.boundary_loop import boundary_loops
from conformorph.pipelines.animation_loop import DEFAULT_LOOP
from conformorph.pipelines.animation_lottie import LottieOptions, lottie_animation
from conformorph.pipelines.animation_svg import (
    AnimationSvgOptions,
    FrameParts,
    animation_svg,
    frames_json,
)
from conformorph.pipelines.atomic_write import atomic_write_bytes, atomic_write_text
from conformorph.pipelines.export_gltf import (
    MorphAppearance,
    MorphOutput,
    write_frame_glb,
    write_morph_glb,
)
from conformorph.pipelines.glb_placement import GlbPlacement, placed_2d_frames
from conformorph.pipelines.morph2d.frame_parts import frame_parts
from conformorph.pipelines.morph2d.strip_png import strip_png

#: Playback rate of ``animation.glb`` (frames per second).
FPS = 30.0
#: Number of frames drawn in ``strip.svg``.
STRIP_FRAMES = 6


def strip_svg(
    frames: NDArray[np.float64], F: NDArray[np.int64], *, count: int = STRIP_FRAMES
) -> str:
    """An SVG drawing of ``count`` evenly spaced frames side by side (y up).

    Parameters
    ----------
    frames : (T, n, 2) float64
    F : (m, 3) int64
    count : int, optional

    Returns
    -------
    str
        A standalone SVG document.
    """
    T = frames.shape[0]
    pick = np.unique(np.round(np.linspace(0, T - 1, min(count, T))).astype(int))
    lo = frames.reshape(-1, 2).min(axis=0)
    hi = frames.reshape(-1, 2).max(axis=0)
    w, h = hi - lo
    size = max(w, h) or 1.0
    gap = 0.15 * size
    stroke = 0.004 * size
    parts = []
    for j, k in enumerate(pick):
        X = frames[k] - lo
        X = np.c_[X[:, 0] + j * (w + gap), h - X[:, 1]]
        tris = " ".join(  # Python floats (format as numpy scalars do, faster)
            "M{:.5g},{:.5g}L{:.5g},{:.5g}L{:.5g},{:.5g}Z".format(*c)
            for c in X[F].reshape(-1, 6).tolist()
        )
        parts.append(f'<path d="{tris}"/>')
        parts.append(
            f'<text x="{j * (w + gap) + 0.5 * w:.5g}" y="{h + 0.08 * size:.5g}" '
            f'font-size="{0.06 * size:.5g}" text-anchor="middle" fill="#333" stroke="none">t={k / max(T - 1, 1):.2f}</text>'
        )
    width = len(pick) * (w + gap) - gap
    return (
        '<svg xmlns="http://www.w3.org/2000/svg" '
        f'viewBox="{-gap / 2:.5g} {-gap / 2:.5g} {width + gap:.5g} {h + gap + 0.1 * size:.5g}">'
        f'<g fill="#cfe3f5" stroke="#2a5d8a" stroke-width="{stroke:.5g}" stroke-linejoin="round">'
        + "".join(parts)
        + "</g></svg>\n"
    )


def frame_rings(
    frames: NDArray[np.float64], F: NDArray[np.int64]
) -> list[list[NDArray[np.float64]]]:
    """Each frame's outline and holes: the mesh's boundary loops, outer first.

    Parameters
    ----------
    frames : (T, n, 2) float64
    F : (m, 3) int64
        Counter-clockwise triangles shared by every frame.

    Returns
    -------
    list of list of (k_r, 2) float64
        Per frame, the outer loop (the one enclosing the largest area in the
        first frame; counter-clockwise) then the holes (clockwise), the same
        vertices in the same order in every frame.
    """
    loops = boundary_loops(F)

    def area(loop: NDArray[np.int64]) -> float:
        x, y = frames[0][loop].T
        return 0.5 * float(abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))

    outer = max(range(len(loops)), key=lambda i: area(loops[i]))
    order = [loops[outer]] + [loop for i, loop in enumerate(loops) if i != outer]
    return [[X[loop] for loop in order] for X in frames]


def write_web_outputs(
    outdir: Path,
    frames: NDArray[np.float64],
    F: NDArray[np.int64],
    times: NDArray[np.float64],
    *,
    loop: str = DEFAULT_LOOP,
    parts: FrameParts | None = None,
) -> dict[str, str]:
    """Write ``animation.svg`` (SMIL), ``animation.json`` (Lottie), both played evenly
    over ``T / FPS`` s, and ``frames.json``.

    Parameters
    ----------
    outdir : Path
    frames : (T, n, 2) float64
    F : (m, 3) int64
    times : (T,) float64
        The morph parameter of each frame (``frame_times`` and ``t`` of
        ``frames.json``).
    loop : {"once", "repeat", "alternate"}, optional
        How ``animation.svg`` plays (:mod:`conformorph.pipelines.animation_loop`).
    parts : list of list of list of (k_r, 2) float64, optional
        Per frame, per part, its outline then its holes; default
        :func:`frame_parts` of the mesh.

    Returns
    -------
    dict
        ``{"animation_svg": "animation.svg", "lottie": "animation.json",
        "frames_json": "frames.json"}``.
    """
    rings: list[list[list[ArrayLike]]] = [
        [list(part) for part in p]
        for p in (parts if parts is not None else frame_parts(frames, F, times).rings)
    ]
    count = frames.shape[0]
    svg_options = AnimationSvgOptions(duration_s=max(count - 1, 1) / FPS, loop=loop)
    even = np.linspace(0.0, 1.0, count)
    atomic_write_text(outdir / "animation.svg", animation_svg(rings, even, options=svg_options))
    lottie = lottie_animation(rings, options=LottieOptions(fps=FPS))
    atomic_write_text(outdir / "animation.json", json.dumps(lottie, separators=(",", ":")) + "\n")
    doc = frames_json(rings, times, frames, F)
    atomic_write_text(outdir / "frames.json", json.dumps(doc, separators=(",", ":")) + "\n")
    return {
        "animation_svg": "animation.svg",
        "lottie": "animation.json",
        "frames_json": "frames.json",
    }


def texture_uv(source_V: NDArray[np.float64]) -> NDArray[np.float64]:
    """UVs mapping the source's bounding box onto the whole image (glTF: v down).

    Parameters
    ----------
    source_V : (n, 2) float64

    Returns
    -------
    (n, 2) float64
        In [0, 1]²; the lowest-left corner of the box gets (0, 1).
    """
    lo = source_V.min(axis=0)
    span = np.maximum(source_V.max(axis=0) - lo, 1e-300)
    u = (source_V - lo) / span
    return np.c_[u[:, 0], 1.0 - u[:, 1]]


def write_morph2d_outputs(
    outdir: Path,
    frames: NDArray[np.float64],
    F: NDArray[np.int64],
    source_V: NDArray[np.float64],
    texture: bytes | None = None,
    per_frame: bool = False,
    times: NDArray[np.float64] | None = None,
    placement: GlbPlacement | None = None,
    *,
    loop: str = DEFAULT_LOOP,
) -> dict[str, Any]:
    """Write ``animation.glb``, ``frames/NNN.glb`` (``per_frame``), ``strip.svg``,
    ``animation.svg``, ``animation.json`` and ``frames.json`` (:func:`write_web_outputs`).

    Parameters
    ----------
    outdir : Path
        Created if missing.
    frames : (T, n, 2) float64
        The frames.
    F : (m, 3) int64
    source_V : (n, 2) float64
        The source mesh, whose bounding box the texture spans (:func:`texture_uv`).
    texture : bytes, optional
        A checked PNG.
    per_frame : bool, optional
    times : (T,) float64, optional
        The morph parameter of each frame (default: evenly spaced in [0, 1]).
    placement : GlbPlacement, optional
        The GLBs' units, size and centring (default: SVG px at 96 dpi, centred, Y up;
        :mod:`conformorph.pipelines.glb_placement`); the SVG outputs keep SVG units.
    loop : {"once", "repeat", "alternate"}, optional
        How ``animation.svg`` plays.

    Returns
    -------
    dict
        The ``outputs`` section of ``metrics.json`` (file names, GLB size).
    """
    count = frames.shape[0]
    outdir.mkdir(parents=True, exist_ok=True)
    uv = texture_uv(source_V) if texture is not None else None
    placed, F_glb, where = placed_2d_frames(frames, F, placement)
    glb = write_morph_glb(
        outdir / "animation.glb",
        placed[0],
        F_glb,
        placed,
        np.arange(count) / FPS,  # played evenly, whatever parameter each frame has
        appearance=MorphAppearance(uv=uv, texture_png=texture),
        name="morph2d",
        output=MorphOutput(extras={"units": "m", "placement": where}),
    )
    outputs: dict[str, Any] = {
        "animation": "animation.glb",
        "animation_bytes": glb["bytes"],
        "glb_placement": where,
    }
    if per_frame:
        width = max(3, len(str(count - 1)))
        for k in range(count):
            write_frame_glb(
                outdir / "frames" / f"{k:0{width}d}.glb",
                placed[k],
                F_glb,
                uv=uv,
                texture_png=texture,
                name=f"frame_{k:0{width}d}",
                extras={"frame": k, "units": "m"},
            )
        outputs["frames"] = [f"frames/{k:0{width}d}.glb" for k in range(count)]
    atomic_write_text(outdir / "strip.svg", strip_svg(frames, F))
    outputs["strip"] = "strip.svg"
    png = strip_png(frames, F, boundary_loops(F), count=STRIP_FRAMES)
    atomic_write_bytes(outdir / "strip.png", png)
    outputs["strip_png"] = "strip.png"
    t = np.linspace(0.0, 1.0, count) if times is None else np.asarray(times, dtype=np.float64)
    outputs.update(write_web_outputs(outdir, frames, F, t, loop=loop))
    return outputs


def write_metrics_json(outdir: Path, result: dict[str, Any]) -> None:
    """Write ``metrics.json`` (indented, newline-terminated) atomically.

    Parameters
    ----------
    outdir : Path
    result : dict
    """
    atomic_write_text(outdir / "metrics.json", json.dumps(result, indent=2) + "\n")
