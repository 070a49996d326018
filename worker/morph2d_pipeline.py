"""2D morph pipeline: load two shapes and anchors, build compatible meshes, morph, write outputs.

``run_morph2d`` is the adapter used by the CLI (``conformorph morph2d``) and by
the worker task behind ``POST /v1/morphs2d``: it reads the inputs, calls the
pure ``geometry`` functions and writes

* ``animation.glb``: the strain-field morph, 2D meshes at z = 0 as morph
  targets with a one-hot LINEAR ``weights`` animation (see
  :mod:`worker.export_gltf`);
* ``frames/000.glb`` … when ``per_frame``;
* ``strip.svg``: a strip of frames (strain method);
* ``metrics.json``: the returned dictionary.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from geometry.arap_interpolation import arap_interpolation
from geometry.compatible_triangulation import compatible_triangulation, min_triangle_angle
from geometry.green_lagrange_strain import signed_areas
from geometry.linear_interpolation import linear_interpolation
from geometry.mesh_errors import FoldedMapError
from geometry.morph_metrics_2d import morph_metrics_2d
from geometry.shape_rings import (
    AnchorOutsideShapeError,
    HoleCorrespondenceError,
    ShapeRings,
    points_in_shape,
    validate_rings,
)
from geometry.strain_morph import strain_morph
from geometry.triangulate_shape import triangulate_polygon
from worker.export_gltf import write_frame_glb, write_morph_glb
from worker.shape_io import read_anchors, read_shape

ProgressFn = Callable[[int, int, str], None]

#: Playback rate of ``animation.glb`` (frames per second).
FPS = 30.0
#: Number of frames drawn in ``strip.svg``.
STRIP_FRAMES = 6


def _atomic_write_text(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, path)


def compatible_meshes(
    source: ShapeRings, target: ShapeRings, anchors: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """Source and target meshes with shared triangles, and a description of how they were made.

    When both shapes have rings of the same lengths and the constrained
    Delaunay triangulation of the source (no Steiner points) is also
    positively oriented on the target, vertex i ↔ vertex i is taken as given
    (the "already compatible" route). Otherwise the compatible triangulation
    of :mod:`geometry.compatible_triangulation` is built.
    """
    if len(source.holes) != len(target.holes):
        raise HoleCorrespondenceError(
            f"the source has {len(source.holes)} hole(s) and the target {len(target.holes)}: "
            "holes cannot correspond"
        )
    same = [r.shape[0] for r in source.rings] == [r.shape[0] for r in target.rings]
    if same:
        V, F = triangulate_polygon(source.outer, holes=source.holes)
        n = V.shape[0]
        T = np.vstack(target.rings)
        if n == T.shape[0] and np.all(signed_areas(T, F) > 0):
            info = {
                "route": "given",
                "vertices": n,
                "triangles": int(F.shape[0]),
                "min_angle_source": min_triangle_angle(V, F),
                "min_angle_target": min_triangle_angle(T, F),
            }
            return V, T, F, info
    ct = compatible_triangulation(source, target, anchors)
    if ct.flipped != (0, 0):
        raise FoldedMapError(
            f"compatible triangulation left {ct.flipped[0]} flipped triangle(s) in the source and "
            f"{ct.flipped[1]} in the target; add anchors near the concave corners"
        )
    info = {
        "route": "constructed",
        "vertices": int(ct.source_V.shape[0]),
        "triangles": ct.n_triangles,
        "boundary_vertices": ct.boundary_vertices,
        "min_angle_source": ct.min_angle[0],
        "min_angle_target": ct.min_angle[1],
        "merged_points": ct.merged_points,
        "repair_rounds": ct.repair_rounds,
        "hole_vertices": ct.hole_vertices,
        "refinement_points": ct.refinement_points,
        "refinement_rounds": ct.refinement_rounds,
        "overlay_triangles": ct.overlay_triangles,
    }
    return ct.source_V, ct.target_V, ct.F, info


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
        tris = " ".join(
            "M{:.5g},{:.5g}L{:.5g},{:.5g}L{:.5g},{:.5g}Z".format(*X[f].ravel()) for f in F
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


def _texture_uv(source_V: NDArray[np.float64]) -> NDArray[np.float64]:
    """UVs mapping the source's bounding box onto the whole image (glTF: v down)."""
    lo = source_V.min(axis=0)
    span = np.maximum(source_V.max(axis=0) - lo, 1e-300)
    u = (source_V - lo) / span
    return np.c_[u[:, 0], 1.0 - u[:, 1]]


def run_morph2d(
    source_path: str | Path,
    target_path: str | Path,
    anchors_path: str | Path,
    outdir: str | Path,
    *,
    frames: int = 60,
    interp: str = "modified",
    per_frame: bool = False,
    progress: ProgressFn | None = None,
    texture_path: str | Path | None = None,
) -> dict[str, Any]:
    """Morph one 2D shape into another and write the outputs to ``outdir``.

    Parameters
    ----------
    source_path, target_path : str or Path
        Shape files (JSON rings or SVG path data), see :mod:`worker.shape_io`.
    anchors_path : str or Path
        Anchors JSON; the first two anchors are the reference points A, B of
        the rigid-motion removal.
    outdir : str or Path
        Output folder (created).
    frames : int, optional
        Number of frames including source and target (≥ 2).
    interp : {"modified", "linear"}, optional
        Strain interpolation, eq. (3) or eq. (2).
    per_frame : bool, optional
        Also write ``frames/NNN.glb``.
    progress : callable, optional
        ``progress(current, total, stage)`` after each stage.
    texture_path : str or Path, optional
        A PNG image spread over the source's bounding box and carried by
        barycentric coordinates (static UVs) through every frame.

    Returns
    -------
    dict
        The content of ``metrics.json``.

    Raises
    ------
    ShapeError (and subclasses), ValueError, OSError, FoldedMapError
        Bad inputs, each with a message naming the problem.
    """
    if frames < 2:
        raise ValueError(f"frames must be at least 2, got {frames}")
    if interp not in ("modified", "linear"):
        raise ValueError(f"interp must be 'modified' or 'linear', got {interp!r}")
    out = Path(outdir)
    total = 6
    step = 0

    def report(stage: str) -> None:
        nonlocal step
        step += 1
        if progress is not None:
            progress(step, total, stage)

    t_start = time.perf_counter()
    source = validate_rings(read_shape(source_path))
    target = validate_rings(read_shape(target_path))
    anchors = read_anchors(anchors_path)
    for side, shape, name in ((0, source, "source"), (1, target, "target")):
        inside = points_in_shape(shape, anchors[:, side])
        if not np.all(inside):
            i = int(np.flatnonzero(~inside)[0])
            raise AnchorOutsideShapeError(
                f"anchor {i} {anchors[i, side].tolist()} lies outside the {name} shape"
            )
    texture = Path(texture_path).read_bytes() if texture_path is not None else None
    report("read")

    t0 = time.perf_counter()
    S, T, F, mesh_info = compatible_meshes(source, target, anchors)
    mesh_info["seconds"] = time.perf_counter() - t0
    mesh_info["orientation_fixes"] = {"source": list(source.fixes), "target": list(target.fixes)}
    report("mesh")

    times = np.linspace(0.0, 1.0, frames)
    seq, info = strain_morph(S, T, F, times, scheme=interp, reference_points=anchors[:2, 0])  # type: ignore[arg-type]
    interp_used, fallback = interp, None
    if not info.converged and interp == "modified":
        # Eq. (3) in the fixed x/y frame can prescribe a strain path along which the
        # minimiser folds a triangle when shears are large (I → L stretches some
        # triangles tenfold along a diagonal; continuation up to N = 64 and eight
        # halvings of the time step do not help, the stuck branch keeps W > 0 at
        # t = 1). Eq. (3) applied in each triangle's principal frame is then used,
        # then eq. (2); the switch is reported in metrics.json ("interp_fallback").
        for alt in ("principal", "linear"):
            seq2, info2 = strain_morph(S, T, F, times, scheme=alt, reference_points=anchors[:2, 0])  # type: ignore[arg-type]
            if info2.converged:
                fallback = (
                    f"modified scheme did not converge "
                    f"({sorted(set(info.stop_reasons) - {'converged'})}); used {alt}"
                )
                seq, info, interp_used = seq2, info2, alt
                break
    report("strain")

    methods: dict[str, Any] = {}
    m = morph_metrics_2d(S, F, seq).as_dict()
    m.update(
        seconds=info.seconds,
        newton_iterations=info.iterations.tolist(),
        continuation=info.continuation.tolist(),
        substeps=info.substeps.tolist(),
        converged=info.converged,
        stop_reasons=list(info.stop_reasons),
        rotation=info.rotation,
        translation=info.translation.tolist(),
    )
    methods["strain"] = m
    t0 = time.perf_counter()
    lin = linear_interpolation(S, T, times)
    methods["linear"] = morph_metrics_2d(S, F, lin).as_dict() | {
        "seconds": time.perf_counter() - t0
    }
    t0 = time.perf_counter()
    arap = arap_interpolation(S, T, F, times)
    methods["arap"] = morph_metrics_2d(S, F, arap).as_dict() | {"seconds": time.perf_counter() - t0}
    report("baselines")

    out.mkdir(parents=True, exist_ok=True)
    uv = _texture_uv(S) if texture is not None else None
    glb = write_morph_glb(
        out / "animation.glb",
        seq[0],
        F,
        seq,
        times * (frames - 1) / FPS,
        uv=uv,
        texture_png=texture,
        name="morph2d",
    )
    outputs: dict[str, Any] = {"animation": "animation.glb", "animation_bytes": glb["bytes"]}
    if per_frame:
        width = max(3, len(str(frames - 1)))
        for k in range(frames):
            write_frame_glb(
                out / "frames" / f"{k:0{width}d}.glb", seq[k], F, uv=uv, texture_png=texture
            )
        outputs["frames"] = [f"frames/{k:0{width}d}.glb" for k in range(frames)]
    _atomic_write_text(out / "strip.svg", strip_svg(seq, F))
    outputs["strip"] = "strip.svg"
    report("outputs")

    result: dict[str, Any] = {
        "source": str(source_path),
        "target": str(target_path),
        "frames": frames,
        "interp": interp,
        "interp_used": interp_used,
        "interp_fallback": fallback,
        "mesh": mesh_info,
        "methods": methods,
        "outputs": outputs,
        "seconds": time.perf_counter() - t_start,
    }
    result["outputs"]["metrics"] = "metrics.json"
    _atomic_write_text(out / "metrics.json", json.dumps(result, indent=2) + "\n")
    report("done")
    return result
