"""2D morph pipeline: load two shapes and anchors, build compatible meshes, morph, write outputs.

``run_morph2d`` is the adapter used by the CLI (``conformorph morph2d``) and by
the worker task behind ``POST /v1/morphs2d``: it reads the inputs, calls the
pure ``geometry`` functions and writes

* ``animation.glb``: the strain-field morph, 2D meshes at z = 0 as morph
  targets with a one-hot LINEAR ``weights`` animation (see
  :mod:`pipelines.export_gltf`);
* ``frames/000.glb`` … when ``per_frame``;
* ``strip.svg``: a strip of frames (strain method);
* ``metrics.json``: the returned dictionary.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from geometry.arap_interpolation import arap_interpolation
from geometry.compatible_triangulation import (
    CompatibleTriangulation,
    compatible_triangulation,
    min_triangle_angle,
)
from geometry.green_lagrange_strain import StrainScheme, signed_areas
from geometry.hole_seeding import seed_missing_holes
from geometry.linear_interpolation import linear_interpolation
from geometry.map_stretch import map_stretch
from geometry.mesh_errors import FoldedMapError
from geometry.morph_metrics_2d import morph_metrics_2d
from geometry.morph_pacing import even_pace_times
from geometry.patch_dissection import dissected_triangulation
from geometry.point_location import locate_points
from geometry.shape_rings import (
    HoleCorrespondenceError,
    PathError,
    ShapeRings,
    check_anchors,
    validate_rings,
)
from geometry.strain_morph import StrainMorphInfo, strain_morph
from geometry.tolerances import STRAIN_MAX_TIME_STEP
from geometry.triangulate_shape import triangulate_polygon
from pipelines.export_gltf import MorphAppearance, write_frame_glb, write_morph_glb
from pipelines.shape_io import DEFAULT_MAX_POINTS, read_anchor_paths, read_anchors, read_shape

ProgressFn = Callable[[int, int, str], None]

#: Playback rate of ``animation.glb`` (frames per second).
FPS = 30.0
#: Number of frames drawn in ``strip.svg``.
STRIP_FRAMES = 6
#: The "already compatible" route (vertex i ↔ vertex i) is taken only if every
#: anchor's source point, carried by that pairing, lands within this fraction of
#: the target's bounding-box diagonal of its target point. Hand-placed anchors
#: carry 3–5 digits (the bar's B: 2.5465 for 2.54648, 1e-5 relative); a pairing
#: that disagrees with the anchors is off by a whole feature (the square whose
#: start vertex is shifted: a side length, 0.7 of the diagonal).
ANCHOR_PAIRING_RTOL = 1e-3
#: The morph has reached the target when its last frame converged and lies
#: within this fraction of the target's bounding-box diagonal of the target mesh
#: (a converged last frame: ~1e-12, see ``STRAIN_NEWTON_STEP_RTOL``).
TARGET_MATCH_RTOL = 1e-6
#: Strain schemes tried, in order, after the requested one fails to converge.
#: samples of the path per output frame from which ``pace="even"`` re-times it
PACE_SAMPLES_PER_FRAME = 4
FALLBACKS = {"modified": ("principal", "linear"), "linear": ("principal", "modified")}
#: Hole pairings tried, cheapest first, when one shape has more holes than the other.
SEED_PAIRINGS_TRIED = 6
#: Newton iterations one strain-morph attempt may spend per solver time step
#: (``strain_morph(max_total_iterations=...)``), so that a hopeless scheme ends
#: instead of running for many minutes before the next is tried. The morphs of
#: ``benchmarks/bench_morph2d.py`` that reach their targets spend 2 (annulus) to 20
#: (stick figures, eq. 2) per step; S -> U with anchors pairing different strokes
#: spent 840 s (2 cores) on one scheme without reaching U.
STRAIN_ITERATIONS_PER_STEP = 50
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


class TextureError(ValueError):
    """The texture is not a readable PNG image."""

    code = "unsupported_image"


class MorphNotConvergedError(ArithmeticError):
    """The strain morph did not reach the target shape with any strain scheme.

    ``metrics`` holds the content of the ``metrics.json`` written before the
    error was raised (every output is written, for inspection).
    """

    code = "morph_not_converged"

    def __init__(self, message: str, metrics: dict[str, Any]):
        super().__init__(message)
        self.metrics = metrics


def _field(exc: BaseException, field: str) -> BaseException:
    """Tag an error with the input it concerns (the API's error ``field``; see worker.job_runner)."""
    if not hasattr(exc, "conformorph_field"):
        exc.conformorph_field = field  # type: ignore[attr-defined]
    return exc


def read_texture_png(path: str | Path) -> bytes:
    """The bytes of a PNG texture, checked (signature and a full decode) before any numerics.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bytes

    Raises
    ------
    TextureError
        If the file is not a PNG image Pillow can decode.
    OSError
        If the file cannot be read.
    """
    import io

    from PIL import Image, UnidentifiedImageError

    data = Path(path).read_bytes()
    name = Path(path).name
    if not data.startswith(_PNG_SIGNATURE):
        raise TextureError(f"{name}: the texture must be a PNG image (no PNG signature)")
    try:
        with Image.open(io.BytesIO(data)) as im:
            im.load()
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise TextureError(f"{name}: not a readable PNG image ({exc})") from exc
    return data


def _atomic_write_text(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, path)


def compatible_meshes(
    source: ShapeRings,
    target: ShapeRings,
    anchors: NDArray[np.float64],
    paths: Sequence[Sequence[int]] = (),
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """Source and target meshes with shared triangles, and a description of how they were made.

    When both shapes have rings of the same lengths, the constrained
    Delaunay triangulation of the source (no Steiner points) is also
    positively oriented on the target, and every anchor pair agrees with the
    pairing (its source point, carried by barycentric coordinates, lands within
    ``ANCHOR_PAIRING_RTOL`` of its target point), vertex i ↔ vertex i is taken
    as given (the "already compatible" route). Otherwise the compatible
    triangulation of :mod:`geometry.compatible_triangulation` is built, glued
    from patches (:func:`geometry.patch_dissection.dissected_triangulation`)
    when ``paths`` are given.

    Parameters
    ----------
    source, target : ShapeRings
    anchors : (a, 2, 2) float64
    paths : sequence of sequences of int, optional
        Dissection paths (anchor indices, :func:`geometry.patch_dissection.dissect_shapes`).

    Returns
    -------
    source_V : (n, 2) float64
    target_V : (n, 2) float64
    F : (m, 3) int64
    info : dict
        ``route`` ("given" or "constructed"), counts, minimum angles, ``stretch``
        (:func:`geometry.map_stretch.map_stretch` of source → target: largest and
        smallest principal stretch and anisotropy); for a refused given route,
        ``given_route_refused`` says why; ``patches`` counts the patches
        (1 without paths, and on the given route, which ignores paths and says
        so in ``paths_ignored``).
    """
    if paths and (source.holes or target.holes):
        raise PathError(
            "paths cannot dissect shapes with holes (their cuts already make a disk)", 0
        )
    if len(source.holes) != len(target.holes):
        return _seeded_meshes(source, target, anchors)
    same = [r.shape[0] for r in source.rings] == [r.shape[0] for r in target.rings]
    refused = None
    if same:
        V, F = triangulate_polygon(source.outer, holes=source.holes)
        n = V.shape[0]
        T = np.vstack(target.rings)
        if n == T.shape[0] and np.all(signed_areas(T, F) > 0):
            refused = _pairing_disagrees(V, T, F, anchors)
            if refused is None:
                info: dict[str, Any] = {
                    "route": "given",
                    "vertices": n,
                    "triangles": int(F.shape[0]),
                    "min_angle_source": min_triangle_angle(V, F),
                    "min_angle_target": min_triangle_angle(T, F),
                    "stretch": map_stretch(V, T, F).as_dict(),
                    "patches": 1,
                }
                if paths:
                    info["paths_ignored"] = "the shapes are compatible already (route 'given')"
                return V, T, F, info
    if paths:
        ct = dissected_triangulation(source, target, anchors, paths)
        V, T, F, info = _constructed(ct, refused=refused)
        info["patches"] = len(paths) + 1
        return V, T, F, info
    ct = compatible_triangulation(source, target, anchors)
    return _constructed(ct, refused=refused)


def _seeded_meshes(
    source: ShapeRings, target: ShapeRings, anchors: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """:func:`compatible_meshes` for shapes with different numbers of holes: a hole one
    shape lacks grows from a seed hole (:func:`geometry.seed_missing_holes`); pairings are
    tried from the cheapest until the holes can be cut to the outer rings consistently."""
    side = "target" if len(source.holes) < len(target.holes) else "source"
    last: HoleCorrespondenceError | None = None
    for rank in range(SEED_PAIRINGS_TRIED):
        try:
            paired = seed_missing_holes(source, target, anchors, pairing_rank=rank)
        except HoleCorrespondenceError as exc:
            last = last or exc
            break
        try:
            ct = compatible_triangulation(
                paired.source, paired.target, anchors, hole_match=range(len(paired.source.holes))
            )
        except HoleCorrespondenceError as exc:
            last = last or exc
            continue
        seeds = [
            {
                "side": sd.side,
                "hole": sd.hole,
                "centre": [float(x) for x in sd.centre],
                "radius": sd.radius,
                "moved": sd.moved,
            }
            for sd in paired.seeds
        ]
        return _constructed(ct, seeds=seeds, pairing_rank=rank)
    assert last is not None
    raise _field(last, side) from last


def _constructed(
    ct: CompatibleTriangulation,
    *,
    refused: str | None = None,
    seeds: list[dict[str, Any]] | None = None,
    pairing_rank: int = 0,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], dict[str, Any]]:
    """The meshes of a compatible triangulation and their description."""
    if ct.flipped != (0, 0):
        raise _field(
            FoldedMapError(
                f"compatible triangulation left {ct.flipped[0]} flipped triangle(s) in the source "
                f"and {ct.flipped[1]} in the target; add anchors near the concave corners"
            ),
            "anchors",
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
        "stretch": map_stretch(ct.source_V, ct.target_V, ct.F).as_dict(),
    }
    if refused is not None:
        info["given_route_refused"] = refused
    if seeds:
        info["seeded_holes"] = seeds
        info["hole_pairing_rank"] = pairing_rank
    return ct.source_V, ct.target_V, ct.F, info


def _pairing_disagrees(
    V: NDArray[np.float64],
    T: NDArray[np.float64],
    F: NDArray[np.int64],
    anchors: NDArray[np.float64],
) -> str | None:
    """Why vertex i ↔ vertex i contradicts the anchors (None when every anchor agrees)."""
    loc = locate_points(V, F, anchors[:, 0])
    carried = np.einsum("pk,pkd->pd", loc.barycentric, T[F[loc.triangle]])
    off = np.linalg.norm(carried - anchors[:, 1], axis=1)
    diag = float(np.linalg.norm(np.ptp(T, axis=0)))
    i = int(np.argmax(off))
    if off[i] <= ANCHOR_PAIRING_RTOL * diag:
        return None
    return (
        f"anchor {i}: vertex i <-> vertex i carries {anchors[i, 0].tolist()} to "
        f"{carried[i].round(6).tolist()}, {off[i] / diag:.3g} of the target's size from "
        f"{anchors[i, 1].tolist()}"
    )


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


def _strain_metrics(
    S: NDArray[np.float64],
    T: NDArray[np.float64],
    F: NDArray[np.int64],
    seq: NDArray[np.float64],
    info: StrainMorphInfo,
    scheme: str,
) -> dict[str, Any]:
    """Metrics of one strain-morph run, with per-frame convergence and the distance to the target."""
    diag = float(np.linalg.norm(np.ptp(T, axis=0)))
    err = float(np.abs(seq[-1] - T).max() / diag)
    m = morph_metrics_2d(S, F, seq).as_dict()
    m.update(
        seconds=info.seconds,
        scheme=scheme,
        newton_iterations=info.iterations.tolist(),
        continuation=info.continuation.tolist(),
        substeps=info.substeps.tolist(),
        converged=info.converged,
        stop_reasons=list(info.stop_reasons),
        frames=[
            {"t": float(t), "converged": r == "converged", "stop_reason": r, "scheme": scheme}
            for t, r in zip(info.times, info.stop_reasons, strict=True)
        ],
        target_error=err,
        reached_target=info.stop_reasons[-1] == "converged" and err <= TARGET_MATCH_RTOL,
        rotation=info.rotation,
        translation=info.translation.tolist(),
    )
    return m


def _not_converged_reason(
    attempts: list[dict[str, Any]], frames: int, stretch: dict[str, Any] | None = None
) -> str:
    """One line: where each scheme stopped, how far the last frame is from the target and
    how much the compatible meshes stretch their triangles (``stretch``, from
    :func:`geometry.map_stretch.map_stretch`): anchors that pair different features of
    the two shapes show as anisotropies in the hundreds (S → U with the corner rule's
    anchors: 493; with its stroke ends paired: 49, and every scheme converges)."""
    parts = []
    for a in attempts:
        bad = [j for j, f in enumerate(a["frames"]) if not f["converged"]]
        if bad:
            f = a["frames"][bad[0]]
            parts.append(
                f"{a['scheme']} stopped at frame {bad[0]} of {frames} "
                f"(t = {f['t']:.3f}, {f['stop_reason']})"
            )
        else:
            parts.append(
                f"{a['scheme']} converged in every frame but ended {a['target_error']:.3g} "
                "of the target's size from it"
            )
    last = attempts[0]
    return (
        "the strain morph did not reach the target: "
        + "; ".join(parts)
        + f"; the last frame ({last['scheme']}) is {last['target_error']:.3g} of the target's "
        "size from it"
        + (
            f"; the compatible meshes stretch a triangle {stretch['max_stretch']:.3g}-fold, "
            f"shorten one to {stretch['min_stretch']:.3g} and distort one "
            f"{stretch['max_anisotropy']:.3g}-fold (largest / smallest stretch)"
            if stretch
            else ""
        )
        + ". Add anchors where the shapes differ most, on corresponding features"
    )


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
    max_points: int = DEFAULT_MAX_POINTS,
    require_convergence: bool = True,
    solver_options: Mapping[str, Any] | None = None,
    pace: str = "strain",
) -> dict[str, Any]:
    """Morph one 2D shape into another and write the outputs to ``outdir``.

    Parameters
    ----------
    source_path, target_path : str or Path
        Shape files (JSON rings or SVG path data), see :mod:`pipelines.shape_io`.
    anchors_path : str or Path
        Anchors JSON; the first two anchors are the reference points A, B of
        the rigid-motion removal.
    outdir : str or Path
        Output folder (created).
    frames : int, optional
        Number of frames including source and target (≥ 2).
    interp : {"modified", "linear"}, optional
        Strain interpolation, eq. (3) or eq. (2). When it does not converge
        the other schemes are tried in the order of ``FALLBACKS`` (eq. 3 in
        each triangle's principal frame first); ``metrics.json`` records the
        scheme used (``interp_used``, per frame under ``methods.strain.frames``)
        and why (``interp_fallback``, ``attempts``).
    per_frame : bool, optional
        Also write ``frames/NNN.glb``.
    progress : callable, optional
        ``progress(current, total, stage)`` after each stage.
    texture_path : str or Path, optional
        A PNG image spread over the source's bounding box and carried by
        barycentric coordinates (static UVs) through every frame; checked
        before any numerics.
    max_points : int, optional
        Most points per shape (``pipelines.shape_io.DEFAULT_MAX_POINTS``).
    require_convergence : bool, optional
        Raise :class:`MorphNotConvergedError` (after writing every output)
        when no scheme reaches the target; False returns the metrics instead.
    solver_options : mapping, optional
        Keyword options of :func:`geometry.strain_morph.strain_morph` (``tol``,
        ``max_iterations``, ``max_continuation``, ``max_substeps``, …), the same
        for every scheme tried.
    pace : {"strain", "even"}, optional
        ``"strain"``: frame k is the strain scheme at t = k/(frames − 1), as the
        paper. ``"even"``: the same path played at the parameter values where
        the largest vertex move is equal between consecutive frames
        (:func:`geometry.morph_pacing.even_pace_times`, from the path sampled
        :data:`PACE_SAMPLES_PER_FRAME` times per frame), which removes eq. (3)'s
        snap at large shears; kept only when it also reaches the target.
        ``metrics.json`` gives the parameter of every frame (``frame_t``).

    Returns
    -------
    dict
        The content of ``metrics.json``.

    Raises
    ------
    ShapeError (and subclasses), ValueError, OSError, FoldedMapError
        Bad inputs, each with a message naming the problem; errors carry the
        input they concern as ``conformorph_field`` ("source", "target",
        "anchors", "anchors[i][side]", "texture").
    MorphNotConvergedError
        When ``require_convergence`` and the last frame did not reach the target.
    """
    if frames < 2:
        raise _field(ValueError(f"frames must be at least 2, got {frames}"), "frames")
    if interp not in FALLBACKS:
        raise _field(ValueError(f"interp must be 'modified' or 'linear', got {interp!r}"), "interp")
    if pace not in ("strain", "even"):
        raise _field(ValueError(f"pace must be 'strain' or 'even', got {pace!r}"), "pace")
    out = Path(outdir)
    total = 6
    step = 0

    def report(stage: str) -> None:
        nonlocal step
        step += 1
        if progress is not None:
            progress(step, total, stage)

    t_start = time.perf_counter()
    shapes = []
    for field, path in (("source", source_path), ("target", target_path)):
        try:
            shapes.append(validate_rings(read_shape(path, max_points=max_points)))
        except ValueError as exc:
            raise _field(exc, field) from None
    source, target = shapes
    try:
        anchors = read_anchors(anchors_path)
        check_anchors(source, target, anchors)
        paths = read_anchor_paths(anchors_path)
    except PathError as exc:
        raise _field(exc, f"paths[{exc.index}]") from None
    except ValueError as exc:
        index, side = getattr(exc, "index", None), getattr(exc, "side", None)
        raise _field(
            exc, "anchors" if index is None or side is None else f"anchors[{index}][{side}]"
        ) from None
    try:
        texture = read_texture_png(texture_path) if texture_path is not None else None
    except (ValueError, OSError) as exc:
        raise _field(exc, "texture") from None
    report("read")

    t0 = time.perf_counter()
    try:
        S, T, F, mesh_info = compatible_meshes(source, target, anchors, paths)
    except PathError as exc:
        raise _field(exc, f"paths[{exc.index}]") from None
    except ValueError as exc:
        raise _field(exc, "anchors") from None
    mesh_info.setdefault("patches", 1)
    mesh_info["seconds"] = time.perf_counter() - t0
    mesh_info["orientation_fixes"] = {"source": list(source.fixes), "target": list(target.fixes)}
    report("mesh")

    times = np.linspace(0.0, 1.0, frames)
    ref = anchors[:2, 0]
    opts = dict(solver_options or {})
    steps = max(
        frames - 1, int(np.ceil(1.0 / float(opts.get("max_time_step", STRAIN_MAX_TIME_STEP))))
    )
    opts.setdefault("max_total_iterations", STRAIN_ITERATIONS_PER_STEP * steps)
    seq, info = strain_morph(S, T, F, times, scheme=interp, reference_points=ref, **opts)  # type: ignore[arg-type]
    attempts = [_strain_metrics(S, T, F, seq, info, interp)]
    interp_used, fallback = interp, None
    if not attempts[0]["reached_target"]:
        # Eq. (3) in the fixed x/y frame can prescribe a strain path along which the
        # minimiser folds a triangle when shears are large (I → L stretches some
        # triangles tenfold along a diagonal; continuation up to N = 64 and eight
        # halvings of the time step do not help, the stuck branch keeps W > 0 at
        # t = 1); eq. (3) fails on others (stick figures). The other schemes are tried in
        # turn; metrics.json records every attempt and the switch.
        for alt in FALLBACKS[interp]:
            seq2, info2 = strain_morph(S, T, F, times, scheme=alt, reference_points=ref, **opts)  # type: ignore[arg-type]
            attempts.append(_strain_metrics(S, T, F, seq2, info2, alt))
            if attempts[-1]["reached_target"]:
                stops = sorted(set(info.stop_reasons) - {"converged"})
                why = (
                    f"did not converge ({stops})"
                    if stops
                    else f"ended {attempts[0]['target_error']:.3g} of the target's size from it"
                )
                fallback = f"{interp} scheme {why}; used {alt}"
                seq, info, interp_used = seq2, info2, alt
                break
    pace_used = "strain"
    used_attempt = next(a for a in attempts if a["scheme"] == interp_used)
    if pace == "even" and used_attempt["reached_target"]:
        # the path sampled finely, re-timed, and solved again at the new times
        fine_t = np.linspace(0.0, 1.0, PACE_SAMPLES_PER_FRAME * (frames - 1) + 1)
        fine_opts = {**opts}
        fine_opts["max_total_iterations"] = STRAIN_ITERATIONS_PER_STEP * max(steps, fine_t.size - 1)
        scheme = cast(StrainScheme, interp_used)
        fine, fine_info = strain_morph(
            S, T, F, fine_t, scheme=scheme, reference_points=ref, **fine_opts
        )
        if fine_info.converged:
            tau = even_pace_times(fine_t, fine, frames)
            seq3, info3 = strain_morph(
                S, T, F, tau, scheme=scheme, reference_points=ref, **fine_opts
            )
            paced = _strain_metrics(S, T, F, seq3, info3, interp_used)
            if paced["reached_target"]:
                seq, info, times, pace_used = seq3, info3, tau, "even"
                attempts = [paced if a is used_attempt else a for a in attempts]
    report("strain")

    methods: dict[str, Any] = {}
    m = next(a for a in attempts if a["scheme"] == interp_used)
    reached = bool(m["reached_target"])
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
        np.arange(frames) / FPS,  # played evenly, whatever parameter each frame has
        appearance=MorphAppearance(uv=uv, texture_png=texture),
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
        "pace": pace,
        "pace_used": pace_used,
        "frame_t": times.tolist(),
        "reached_target": reached,
        "not_converged_reason": (
            None if reached else _not_converged_reason(attempts, frames, mesh_info.get("stretch"))
        ),
        "attempts": [
            {k: a[k] for k in ("scheme", "converged", "reached_target", "target_error")}
            for a in attempts
        ],
        "mesh": mesh_info,
        "methods": methods,
        "outputs": outputs,
        "seconds": time.perf_counter() - t_start,
    }
    result["outputs"]["metrics"] = "metrics.json"
    _atomic_write_text(out / "metrics.json", json.dumps(result, indent=2) + "\n")
    report("done")
    if not reached and require_convergence:
        raise MorphNotConvergedError(str(result["not_converged_reason"]), result)
    return result
