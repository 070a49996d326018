"""Benchmark of anchor-free outline matching (issue 18), with a flubber comparison.

Run:  .venv/bin/python benchmarks/bench_outline_matching.py [--no-flubber] [--budget 200]

Pairs: every pair the committed anchors fixtures pair (``tests/fixtures/shapes/anchors_*.json``),
plus horse → heart, horse → chair, heart → star, star → horse, figure_stand → figure_jump and
each DejaVu letter to the next (A → B → C → I → L → S → T → U → Z). Shapes are read from
``../shared/data/shapes`` when there, else from the fixtures.

Table 1, per pair: the automatic match (:func:`geometry.outline_correspondence.match_outlines`)
— pairs (features + fills), rotation, seconds for matching alone and for matching + hole
pairing + simplification of both shapes to the point budget (matched points kept) — and,
where a fixture anchors file exists, the distance of each of its boundary anchors to the
nearest matched pair, as the larger of the source-side and target-side distances, each
relative to its shape's diameter (median and max; 0 = the anchor was found).

Table 2 (when ``node`` and ``npm`` work): ``flubber.interpolate(a, b, {string: false})``
(npm flubber 0.4.2, installed into a temporary folder, never the repository's
package.json) on the same outer rings at 61 evenly spaced t; frames whose outline
self-intersects (shapely ``is_simple``) and the smallest and largest area over the
source's. Beside it the same counts for the straight-line interpolation of the two
outlines resampled between our matched points ("matched linear": an outline-only
baseline that shows what the correspondences alone do; the strain morph adds the
interior mesh).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from shapely.geometry import LinearRing, Point, Polygon

from geometry.hole_pairing import pair_holes
from geometry.outline_correspondence import OutlineMatch, match_outlines
from geometry.outline_features import ring_arc_positions, ring_points_at
from geometry.outline_simplification import SimplifyOptions, simplify_rings
from pipelines.shape_io import read_anchors, read_shape

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "shapes"
SHARED = ROOT.parent / "shared" / "data" / "shapes"
LETTERS = "ABCILSTUZ"
EXTRA = [
    ("flubber_horse", "flubber_heart"),
    ("flubber_horse", "flubber_chair"),
    ("flubber_heart", "flubber_star"),
    ("flubber_star", "flubber_horse"),
    ("figure_stand", "figure_jump"),
] + [(f"dejavu_bold_{a}", f"dejavu_bold_{b}") for a, b in zip(LETTERS, LETTERS[1:], strict=False)]
FRAMES = 61

NODE_SCRIPT = r"""
const flubber = require(process.env.FLUBBER_PATH);
const pairs = JSON.parse(require('fs').readFileSync(0, 'utf8'));
const out = pairs.map(([a, b, n]) => {
  const f = flubber.interpolate(a, b, {string: false});
  const frames = [];
  for (let k = 0; k < n; k++) frames.push(f(k / (n - 1)));
  return frames;
});
process.stdout.write(JSON.stringify(out));
"""


def _shape(name: str) -> list[np.ndarray]:
    for folder in (SHARED, FIXTURES):
        if (folder / f"{name}.json").exists():
            return read_shape(folder / f"{name}.json")
    raise FileNotFoundError(name)


def _pairs() -> list[tuple[str, str, Path | None]]:
    out: list[tuple[str, str, Path | None]] = []
    for f in sorted(FIXTURES.glob("anchors_*__*.json")):
        a, b = f.stem.removeprefix("anchors_").split("__")
        out.append((a, b, f))
    seen = {(a, b) for a, b, _ in out}
    out += [(a, b, None) for a, b in EXTRA if (a, b) not in seen]
    return out


def _diameter(P: np.ndarray) -> float:
    return float(np.ptp(P, axis=0).max())


def _anchor_distances(
    m: OutlineMatch, anchors: np.ndarray, src: np.ndarray, tgt: np.ndarray
) -> list[float]:
    """Per boundary fixture anchor: min over matched pairs of max(source, target) relative distance."""
    ds, dt = _diameter(src), _diameter(tgt)
    ring_s, ring_t = LinearRing(src), LinearRing(tgt)
    out = []
    for ps, pt in anchors:
        if ring_s.distance(Point(ps)) > 1e-6 * ds or ring_t.distance(Point(pt)) > 1e-6 * dt:
            continue  # interior anchor (a dissection path's): not on the outline
        d = np.maximum(
            np.linalg.norm(m.source_points - ps, axis=1) / ds,
            np.linalg.norm(m.target_points - pt, axis=1) / dt,
        )
        out.append(float(d.min()))
    return out


def _matched_linear(
    m: OutlineMatch, src: np.ndarray, tgt: np.ndarray, n: int = 400
) -> list[np.ndarray]:
    """Outlines resampled piecewise between the matched points, then interpolated linearly."""
    s, Ls = ring_arc_positions(src)
    t, Lt = ring_arc_positions(tgt)
    a = (s / Ls)[m.source_index]
    b = (t / Lt)[m.target_index]
    order = np.argsort(a)
    a, b = a[order], b[order]
    b = b[0] + np.concatenate([[0.0], np.cumsum(np.mod(np.diff(b), 1.0))])
    ua = np.concatenate([a, [a[0] + 1.0]])
    ub = np.concatenate([b, [b[0] + 1.0]])
    grid = a[0] + np.arange(n) / n
    A = ring_points_at(src, grid)
    B = ring_points_at(tgt, np.interp(grid, ua, ub))
    return [(1 - x) * A + x * B for x in np.linspace(0, 1, FRAMES)]


def _frame_stats(frames: list[np.ndarray], source_area: float) -> tuple[int, float, float]:
    bad = 0
    ratios = []
    for f in frames:
        P = np.asarray(f, dtype=float)
        if not LinearRing(P).is_simple:
            bad += 1
        ratios.append(abs(Polygon(P).area) / source_area)
    return bad, min(ratios), max(ratios)


def _flubber(pairs: list[tuple[np.ndarray, np.ndarray]]) -> list[list[np.ndarray]] | None:
    node, npm = shutil.which("node"), shutil.which("npm")
    if not node or not npm:
        return None
    with tempfile.TemporaryDirectory(prefix="flubber_") as tmp:
        subprocess.run(
            [npm, "install", "--no-save", "--no-package-lock", "--prefix", tmp, "flubber@0.4.2"],
            check=True,
            capture_output=True,
            timeout=300,
        )
        payload = json.dumps([[a.tolist(), b.tolist(), FRAMES] for a, b in pairs])
        res = subprocess.run(
            [node, "-e", NODE_SCRIPT],
            env={**os.environ, "FLUBBER_PATH": str(Path(tmp) / "node_modules" / "flubber")},
            input=payload,
            capture_output=True,
            text=True,
            check=True,
            timeout=600,
        )
    return [[np.asarray(f, dtype=float) for f in frames] for frames in json.loads(res.stdout)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--no-flubber", action="store_true")
    ap.add_argument("--budget", type=int, default=200, help="points per shape after simplification")
    args = ap.parse_args()
    rows = []
    print(
        "| pair | pts | pairs (feat+fill) | rot ° | match s | +holes+simplify s | pts after | fixture anchors: median / max dist |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for a, b, fixture in _pairs():
        rs, rt = _shape(a), _shape(b)
        t0 = time.perf_counter()
        m = match_outlines(rs[0], rt[0])
        t1 = time.perf_counter()
        pair_holes(rs[1:], rt[1:], source_outer=rs[0], target_outer=rt[0], rotation=m.rotation)
        opts = SimplifyOptions(budget=args.budget)
        ss = simplify_rings(rs, keep_points=m.source_points, options=opts)
        st = simplify_rings(rt, keep_points=m.target_points, options=opts)
        t2 = time.perf_counter()
        n_feat = sum(o == "feature" for o in m.origin)
        dist = ""
        if fixture is not None:
            d = _anchor_distances(m, read_anchors(fixture), rs[0], rt[0])
            dist = f"{np.median(d):.3f} / {max(d):.3f} ({len(d)}): " + " ".join(
                f"{x:.2f}" for x in d
            )
        after = f"{sum(map(len, ss.rings))}/{sum(map(len, st.rings))}"
        print(
            f"| {a} → {b} | {sum(map(len, rs))}/{sum(map(len, rt))} | {n_feat}+{len(m.origin) - n_feat} "
            f"| {np.degrees(m.rotation):.0f} | {t1 - t0:.3f} | {t2 - t0:.3f} | {after} | {dist} |"
        )
        rows.append((a, b, rs[0], rt[0], m))
    if args.no_flubber:
        return
    frames = _flubber([(r[2], r[3]) for r in rows])
    if frames is None:
        print("\nnode/npm not found: no flubber comparison")
        return
    print(
        f"\nOuter rings, {FRAMES} frames at even t: self-intersecting frames, area / source (min-max)\n"
    )
    print(
        "| pair | flubber: bad frames | flubber: area ratio | matched linear: bad | matched linear: area ratio |"
    )
    print("|---|---|---|---|---|")
    for (a, b, src, tgt, m), fl in zip(rows, frames, strict=True):
        area = abs(Polygon(src).area)
        fb, flo, fhi = _frame_stats(fl, area)
        ob, olo, ohi = _frame_stats(_matched_linear(m, src, tgt), area)
        print(f"| {a} → {b} | {fb} | {flo:.2f}-{fhi:.2f} | {ob} | {olo:.2f}-{ohi:.2f} |")


if __name__ == "__main__":
    main()
