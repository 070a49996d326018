"""``conformorph demo``: the conformal core on a bundled face, with a figure like the paper's Fig. 4.

Runs the disk conformal map (the paper's QIEM route by default) and the
Algorithm 1 reconstruction on ``cli/data/demo_face.obj`` (a cropped MeshMonk
template, see ``cli/data/README.md``) and writes into the output folder:

- ``demo_figure.png``: (a) a checkerboard on the disk over the mapped mesh,
  (b) the same checkerboard pulled back to the face through the inverse map,
  (c) the histogram of the angle distortion, (d) the reconstructed face;
- ``demo_map.npz`` (``uv``, ``faces``, ``kept``), ``demo_reconstructed.obj``,
  both with the input's vertices in its order (as ``conformorph map`` and
  ``reconstruct`` write them, whatever ``--fill-holes`` / ``--remove-ears`` did);
- ``demo.json``: timings, map quality, reconstruction errors.

The figure is drawn with a small orthographic rasteriser in numpy and Pillow
(no plotting library): every pixel of a triangle interpolates the disk
coordinates barycentrically, so the checkerboard is sharp on the face.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from conformorph import geometry
from conformorph.geometry.map_quality import map_quality
from conformorph.pipelines.conformal import (
    CurvatureOptions,
    DiskMapOptions,
    ReconstructionStepOptions,
    RepairOptions,
    curvature_step,
    disk_map_step,
    load_disk_mesh,
    reconstruction_step,
    require_interior_vertex,
)
from conformorph.pipelines.mesh_io import write_obj

DEMO_FACE = Path(__file__).resolve().parent / "data" / "demo_face.obj"
PANEL = 420  # pixels per panel side
CHECKS = 10  # checkerboard squares across the disk's diameter
LIGHT = np.array([0.25, 0.35, 1.0]) / np.linalg.norm([0.25, 0.35, 1.0])
CHECK_COLOURS = np.array([[233, 84, 32], [250, 246, 238]], dtype=np.float64)


def rasterize(
    P: np.ndarray, depth: np.ndarray, F: np.ndarray, attrs: np.ndarray, size: int
) -> tuple[np.ndarray, np.ndarray]:
    """Orthographic rasterisation with barycentric attribute interpolation.

    Triangles are filled far to near (painter's algorithm, by mean depth) into
    an integer face-id image with Pillow; then every covered pixel
    interpolates the attributes of its triangle at the pixel centre.

    Parameters
    ----------
    P : (n, 2) float64
        Vertex positions in pixels (x right, y down).
    depth : (n,) float64
        Larger is nearer the viewer.
    F : (m, 3) int64
    attrs : (n, k) float64
        Per-vertex attributes to interpolate.
    size : int
        Image width and height.

    Returns
    -------
    image : (size, size, k) float64
        Interpolated attributes (0 where no triangle covers the pixel).
    face_id : (size, size) int64
        Visible triangle per pixel, −1 for background.
    """
    ids = Image.new("I", (size, size), -1)
    draw = ImageDraw.Draw(ids)
    for f in np.argsort(depth[F].mean(axis=1), kind="stable"):
        draw.polygon([(float(x), float(y)) for x, y in P[F[f]]], fill=int(f))
    face_id = np.asarray(ids, dtype=np.int64).copy()
    image = np.zeros((size, size, attrs.shape[1]))
    ys, xs = np.nonzero(face_id >= 0)
    f = face_id[ys, xs]
    a, b, c = P[F[f, 0]], P[F[f, 1]], P[F[f, 2]]
    px, py = xs + 0.5, ys + 0.5
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    det = np.where(np.abs(det) < 1e-12, 1e-12, det)
    w1 = ((px - a[:, 0]) * (c[:, 1] - a[:, 1]) - (py - a[:, 1]) * (c[:, 0] - a[:, 0])) / det
    w2 = ((b[:, 0] - a[:, 0]) * (py - a[:, 1]) - (b[:, 1] - a[:, 1]) * (px - a[:, 0])) / det
    # pixels that Pillow's fill rule put just outside the triangle: clamp into it
    w1 = w1.clip(0, 1)
    w2 = w2.clip(0, 1)
    over = w1 + w2 > 1
    w1[over], w2[over] = w1[over] / (w1 + w2)[over], w2[over] / (w1 + w2)[over]
    w0 = 1.0 - w1 - w2
    image[ys, xs] = (
        w0[:, None] * attrs[F[f, 0]] + w1[:, None] * attrs[F[f, 1]] + w2[:, None] * attrs[F[f, 2]]
    )
    return image, face_id


def _view(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Rows: screen right, screen up, towards the viewer (an orthonormal frame)."""
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(axis=0)
    toward = n / np.linalg.norm(n)
    up = np.array([0.0, 1.0, 0.0])
    if abs(up @ toward) > 0.9:
        up = np.array([0.0, 0.0, 1.0])
    up = up - (up @ toward) * toward
    up /= np.linalg.norm(up)
    return np.stack([np.cross(up, toward), up, toward])


def _checker(uv: np.ndarray) -> np.ndarray:
    """(…, 2) disk coordinates -> (…,) checkerboard parity 0/1."""
    k = np.floor((uv + 1.0) * CHECKS / 2.0).astype(np.int64)
    return np.asarray((k[..., 0] + k[..., 1]) % 2)


def render_face(
    V: np.ndarray, F: np.ndarray, uv: np.ndarray, frame: np.ndarray, size: int = PANEL
) -> Image.Image:
    """The surface seen frontally, shaded, coloured by the checkerboard of its disk map."""
    Q = V @ frame.T
    lo, hi = Q[:, :2].min(axis=0), Q[:, :2].max(axis=0)
    s = 0.9 * size / float((hi - lo).max())
    P = np.column_stack(
        [
            (Q[:, 0] - (lo[0] + hi[0]) / 2) * s + size / 2,
            size / 2 - (Q[:, 1] - (lo[1] + hi[1]) / 2) * s,
        ]
    )
    img, fid = rasterize(P, Q[:, 2], F, uv, size)
    fn = np.cross(Q[F[:, 1]] - Q[F[:, 0]], Q[F[:, 2]] - Q[F[:, 0]])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    shade = 0.3 + 0.7 * np.abs(fn @ LIGHT)
    rgb = np.full((size, size, 3), 255.0)
    hit = fid >= 0
    col = CHECK_COLOURS[_checker(img[hit])]
    rgb[hit] = col * shade[fid[hit], None]
    return Image.fromarray(rgb.clip(0, 255).astype(np.uint8))


def render_disk(uv: np.ndarray, F: np.ndarray, size: int = PANEL) -> Image.Image:
    """The disk map: checkerboard inside the mapped mesh, mesh edges drawn thinly."""
    P = np.column_stack([(uv[:, 0] * 0.45 + 0.5) * size, (0.5 - uv[:, 1] * 0.45) * size])
    img, fid = rasterize(P, np.zeros(len(uv)), F, uv, size)
    rgb = np.full((size, size, 3), 255.0)
    hit = fid >= 0
    rgb[hit] = CHECK_COLOURS[_checker(img[hit])]
    im = Image.fromarray(rgb.astype(np.uint8))
    draw = ImageDraw.Draw(im)
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0
    )
    if edges.shape[0] <= 20000:
        for i, j in edges:
            draw.line([tuple(P[i]), tuple(P[j])], fill=(90, 90, 90), width=1)
    c = size / 2
    r = 0.45 * size
    draw.ellipse([c - r, c - r, c + r, c + r], outline=(0, 0, 0), width=2)
    return im


def render_histogram(
    counts: np.ndarray, edges: np.ndarray, above: int, size: int = PANEL
) -> Image.Image:
    """Bar chart of a histogram (counts as a percentage of all values)."""
    im = Image.new("RGB", (size, size), "white")
    draw = ImageDraw.Draw(im)
    font = ImageFont.load_default()
    left, right, top, bottom = 50, size - 15, 20, size - 45
    total = max(int(counts.sum()) + above, 1)
    pct = 100.0 * counts / total
    ymax = max(float(pct.max()), 1e-9) * 1.1
    nb = counts.size
    bw = (right - left) / nb
    for i, p in enumerate(pct):
        h = (bottom - top) * p / ymax
        draw.rectangle(
            [left + i * bw + 1, bottom - h, left + (i + 1) * bw - 1, bottom], fill=(52, 101, 164)
        )
    draw.line([left, bottom, right, bottom], fill="black")
    draw.line([left, top, left, bottom], fill="black")
    for t in np.linspace(edges[0], edges[-1], 6):
        x = left + (t - edges[0]) / (edges[-1] - edges[0]) * (right - left)
        draw.line([x, bottom, x, bottom + 4], fill="black")
        draw.text((x - 8, bottom + 6), f"{t:g}", fill="black", font=font)
    for frac in (0.0, 0.5, 1.0):
        y = bottom - frac * (bottom - top)
        draw.text((4, y - 6), f"{frac * ymax:.1f}%", fill="black", font=font)
    draw.text((left + 60, bottom + 24), "angle distortion (degrees)", fill="black", font=font)
    if above:
        draw.text((right - 150, top), f"{above} corners > {edges[-1]:g}°", fill="black", font=font)
    return im


def compose_figure(panels: list[tuple[str, Image.Image]]) -> Image.Image:
    """Panels side by side with a caption above each."""
    font = ImageFont.load_default()
    w = sum(p.width for _, p in panels)
    h = max(p.height for _, p in panels) + 40
    fig = Image.new("RGB", (w, h), "white")
    draw = ImageDraw.Draw(fig)
    x = 0
    for title, p in panels:
        fig.paste(p, (x, 40))
        for line_no, line in enumerate(title.split("\n")):
            draw.text((x + 10, 6 + 14 * line_no), line, fill="black", font=font)
        x += p.width
    return fig


def run_demo(args: argparse.Namespace) -> int:
    """Map and reconstruct the bundled face; write the figure, the outputs and a JSON summary."""
    t0 = time.perf_counter()
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    mesh = load_disk_mesh(
        args.mesh or DEMO_FACE,
        RepairOptions(fill_holes=args.fill_holes, remove_ears=args.remove_ears),
    )
    V, F = mesh.V, mesh.F
    require_interior_vertex(F, "demo")
    seconds: dict[str, float] = {}

    t = time.perf_counter()
    mapped = disk_map_step(mesh, DiskMapOptions(method=args.method, fold_policy="report"))
    uv, info = mapped.uv, mapped.info
    seconds["map"] = time.perf_counter() - t
    quality = map_quality(V, F, uv, geometry.boundary_loop(F))

    t = time.perf_counter()
    # as 'conformorph reconstruct': from the harmonic map, without the angle refinement
    harmonic = disk_map_step(
        mesh, DiskMapOptions(method=args.method, fold_policy="report", refine_angles=False)
    )
    hl = curvature_step(mesh, harmonic.uv, CurvatureOptions(curvature="vector"))
    rec = reconstruction_step(
        mesh, harmonic.uv, hl.H, hl.lam, ReconstructionStepOptions(fold_correction=False)
    )
    X, rinfo, errors = rec.X, rec.info, rec.errors
    seconds["reconstruct"] = time.perf_counter() - t

    t = time.perf_counter()
    frame = _view(V, F)
    d = geometry.angle_distortion(V, F, uv).reshape(-1)
    edges = np.linspace(0.0, 10.0, 41)
    counts, _ = np.histogram(d[d <= edges[-1]], bins=edges)
    panels = [
        ("(a) disk conformal map\n(checkerboard on the disk)", render_disk(uv, F)),
        ("(b) checkerboard pulled back\nto the face", render_face(V, F, uv, frame)),
        (
            f"(c) angle distortion: mean {quality.angle_distortion_mean:.2f}°,\n"
            f"max {quality.angle_distortion_max:.1f}°, {quality.flipped} flipped",
            render_histogram(counts, edges, int((d > edges[-1]).sum())),
        ),
        (
            f"(d) reconstructed from (H, lambda): relative\nerror L2 {errors['L2']:.1e}, Linf {errors['Linf']:.1e}",
            render_face(X, F, uv, frame),
        ),
    ]
    png = out / "demo_figure.png"
    compose_figure(panels).save(png)
    seconds["figure"] = time.perf_counter() - t

    np.savez(out / "demo_map.npz", uv=mapped.uv_input, faces=mesh.F_in, kept=mapped.kept)
    write_obj(out / "demo_reconstructed.obj", rec.X_input, mesh.F_in)
    seconds["total"] = time.perf_counter() - t0
    result: dict[str, Any] = {
        "mesh": str(args.mesh or DEMO_FACE),
        "vertices": int(mesh.V_in.shape[0]),
        "faces": int(mesh.F_in.shape[0]),
        "mapped_vertices": int(V.shape[0]),
        **mesh.done,
        "method": args.method,
        "figure": str(png),
        "quality": quality.to_dict(),
        "map_info": info.to_dict(),
        "relative_error": errors,
        "reconstruction": rinfo.to_dict(),
        "seconds": seconds,
    }
    (out / "demo.json").write_text(json.dumps(result, indent=1) + "\n")
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"{png}: {V.shape[0]} vertices; map ({args.method}) mean angle distortion "
            f"{quality.angle_distortion_mean:.3f}°, {quality.flipped} flipped; reconstruction "
            f"relative L2 {errors['L2']:.2e}, L∞ {errors['Linf']:.2e}; {seconds['total']:.2f} s"
        )
    return 0


def register(sub: Any) -> None:
    """Add the ``demo`` command."""
    p = sub.add_parser(
        "demo", help="map and reconstruct a bundled face; write a figure like the paper's Fig. 4"
    )
    p.add_argument("-o", "--output", default="conformorph-demo", help="output folder (created)")
    p.add_argument("--method", choices=["qiem", "fast"], default="qiem", help="disk map method")
    p.add_argument("--mesh", default=None, help="use this disk mesh instead of the bundled face")
    p.add_argument("--fill-holes", action="store_true", help="fill inner boundary loops first")
    p.add_argument("--remove-ears", action="store_true", help="remove boundary ear vertices first")
    p.add_argument("--json", action="store_true", help="print the JSON summary")
    p.set_defaults(handler=run_demo)
