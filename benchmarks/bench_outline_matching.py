"""Benchmark of anchor-free outline matching (issue 18), with a flubber comparison.

Run:  .venv/bin/python benchmarks/bench_outline_matching.py [--no-flubber] [--budget 200]
          [--no-morph] [--frames 60] [--only PAIR,...] [--pair-timeout 300]

Pairs: every pair the committed anchors fixtures pair (``tests/fixtures/shapes/anchors_*.json``),
plus horse → heart, horse → chair, heart → star, star → horse, figure_stand → figure_jump and
each DejaVu letter to the next (A → B → C → I → L → S → T → U → Z). Shapes are read from
``../shared/data/shapes`` (or ``$CONFORMORPH_SHARED_SHAPES``, for a git worktree) when
there, else from the fixtures.

Table 1, per pair: the automatic match (:func:`conformorph.geometry.outline_correspondence.match_outlines`)
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

Table 3 (unless ``--no-morph``), our morph against flubber on the same outlines and
the same frame times: per pair, ``conformorph morph2d SOURCE TARGET --frames 60``
with no anchors file (``--with-anchors``: with each pair's committed anchors file, pairs
without one left out) and every other option at its default, run as a fresh process
(seconds end to end = its wall time, Python start-up included; capped by
``--pair-timeout``); from its ``metrics.json`` the compatible mesh's vertices, the
Newton iterations, flipped triangle-frames, the smallest triangle area ratio,
whether the last frame reached the target, and the bar-pair "no squeezing beyond
the endpoints" measure (``morph_metrics_2d.max_squeeze_excess``: the largest
excursion of a triangle's area ratio outside [1, its final ratio]; no squeezing ⇔
≤ 0.05); from its ``frames.json`` each frame's outline and holes. Then flubber
(``interpolate`` with its defaults) on the two shapes' outer rings at the frame
times ``metrics.json`` reports. For both: frames whose outer ring self-intersects
(shapely ``LinearRing.is_simple``; for ours also frames whose polygon with its
holes is not ``is_valid``), the smallest and largest outer-ring area over frame
0's, and the same no-squeezing measure on the whole outline's area (excursion of
area / frame 0's area outside [1, last frame's]; flubber has no mesh).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from shapely.geometry import LinearRing, Point, Polygon

from conformorph.geometry.hole_pairing import pair_holes
from conformorph.geometry.outline_correspondence import OutlineMatch, match_outlines
from conformorph.geometry.outline_features import ring_arc_positions, ring_points_at
from conformorph.geometry.outline_simplification import SimplifyOptions, simplify_rings
from conformorph.pipelines.shape_io import read_anchors, read_shape

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "shapes"
# A git worktree (for example /work/wt/NAME) is not beside shared/: CONFORMORPH_SHARED_SHAPES
# names the folder then.
SHARED = Path(
    os.environ.get("CONFORMORPH_SHARED_SHAPES", ROOT.parent / "shared" / "data" / "shapes")
)
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
const out = pairs.map(([a, b, times]) => {
  const t0 = process.hrtime.bigint();
  const f = flubber.interpolate(a, b, {string: false});
  const frames = times.map((t) => f(t));
  return {frames, seconds: Number(process.hrtime.bigint() - t0) / 1e9};
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


def _install_flubber(tmp: str) -> Path | None:
    """npm flubber 0.4.2 installed into ``tmp`` (never the repository's package.json)."""
    node, npm = shutil.which("node"), shutil.which("npm")
    if not node or not npm:
        return None
    subprocess.run(
        [npm, "install", "--no-save", "--no-package-lock", "--prefix", tmp, "flubber@0.4.2"],
        check=True,
        capture_output=True,
        timeout=300,
    )
    return Path(tmp) / "node_modules" / "flubber"


def _flubber(
    flubber: Path, pairs: list[tuple[np.ndarray, np.ndarray, list[float]]]
) -> list[tuple[list[np.ndarray], float]]:
    """Per pair, flubber's outline at each time and its seconds (interpolator + frames)."""
    payload = json.dumps([[a.tolist(), b.tolist(), list(t)] for a, b, t in pairs])
    res = subprocess.run(
        [str(shutil.which("node")), "-e", NODE_SCRIPT],
        env={**os.environ, "FLUBBER_PATH": str(flubber)},
        input=payload,
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    return [
        ([np.asarray(f, dtype=float) for f in r["frames"]], float(r["seconds"]))
        for r in json.loads(res.stdout)
    ]


_NUMBER_PAIR = re.compile(r"(-?[0-9.eE+-]+),(-?[0-9.eE+-]+)")


def path_d_ring(d: str) -> np.ndarray:
    """(n, 2) ring of one ``M x,y L x,y … Z`` path (frames.json), back to y up.

    >>> path_d_ring("M0.0,0.0 L1.0,0.0 L0.0,-1.0 Z").tolist()
    [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    """
    P = np.array([[float(x), float(y)] for x, y in _NUMBER_PAIR.findall(d)])
    return P * [1.0, -1.0]


def outline_stats(frames: list[list[np.ndarray]]) -> dict[str, float]:
    """Self-intersections, area ratios and the outline no-squeeze excess of a ring sequence.

    Parameters
    ----------
    frames : list of list of (n_r, 2) arrays
        Per frame the outer ring, then the holes (none for flubber).

    Returns
    -------
    dict
        ``crossing`` frames whose outer ring is not simple, ``invalid`` frames
        whose polygon with holes is not valid, ``min`` / ``max`` outer-ring area
        over frame 0's, ``excess`` the largest relative excursion of the whole
        shape's area over frame 0's outside [1, last frame's] (0 inside).
    """
    outer = np.array([abs(Polygon(f[0]).area) for f in frames])
    whole = np.array([abs(Polygon(f[0], f[1:]).area) for f in frames])
    r = whole / whole[0]
    lo, hi = min(1.0, r[-1]), max(1.0, r[-1])
    excess = max(0.0, float(np.max((lo - r) / lo)), float(np.max((r - hi) / hi)))
    return {
        "crossing": sum(not LinearRing(f[0]).is_simple for f in frames),
        "invalid": sum(not Polygon(f[0], f[1:]).is_valid for f in frames),
        "min": float(outer.min() / outer[0]),
        "max": float(outer.max() / outer[0]),
        "excess": excess,
    }


def _shape_path(name: str) -> Path:
    for folder in (SHARED, FIXTURES):
        if (folder / f"{name}.json").exists():
            return folder / f"{name}.json"
    raise FileNotFoundError(name)


def _our_morph(
    a: str, b: str, out: Path, frames: int, timeout: float, anchors: Path | None = None
) -> dict | None:
    """``conformorph morph2d A B --frames N [--anchors FILE]`` (otherwise defaults) as a
    fresh process."""
    exe = Path(sys.executable).parent / "conformorph"
    cmd = [str(exe), "morph2d", str(_shape_path(a)), str(_shape_path(b))]
    if anchors is not None:
        cmd += ["--anchors", str(anchors)]
    t0 = time.perf_counter()
    try:
        rc = subprocess.run(
            [*cmd, "--frames", str(frames), "-o", str(out), "--quiet"],
            capture_output=True,
            text=True,
            timeout=timeout,
        ).returncode
    except subprocess.TimeoutExpired:
        return None
    wall = time.perf_counter() - t0
    if not (out / "metrics.json").exists():
        return {"rc": rc, "wall": wall}
    m = json.loads((out / "metrics.json").read_text())
    fj = json.loads((out / "frames.json").read_text())
    rings = [[path_d_ring(f["outline"]), *map(path_d_ring, f["holes"])] for f in fj["frames"]]
    return {"rc": rc, "wall": wall, "metrics": m, "rings": rings}


def morph_table(
    names: list[tuple[str, str, Path | None]],
    frames: int,
    timeout: float,
    no_flubber: bool = False,
    with_anchors: bool = False,
) -> None:
    """Table 3: our morph and flubber on the same outlines at the same frame times; with
    ``with_anchors`` our morph is given each pair's committed anchors file."""
    with tempfile.TemporaryDirectory(prefix="bench_web2d_") as tmp:
        flubber = None if no_flubber else _install_flubber(tmp)
        given = "the committed anchors" if with_anchors else "no anchors"
        print(f"\n## Table 3: our morph ({given}, defaults, {frames} frames) and flubber\n")
        print(
            "| pair | V | s (wall) | Newton it | flips | min tri area | reached | mesh squeeze "
            "| ours: crossing / invalid | ours: area | ours: outline squeeze "
            "| flubber: crossing | flubber: area | flubber: outline squeeze | flubber s |"
        )
        print("|---" * 15 + "|")
        for a, b, fixture in names:
            anchors = fixture if with_anchors else None
            res = _our_morph(a, b, Path(tmp) / f"{a}__{b}", frames, timeout, anchors)
            label = f"{a} → {b}"
            if res is None or "metrics" not in res:
                why = f"timeout {timeout:.0f} s" if res is None else f"exit {res['rc']}, no metrics"
                print(f"| {label} | {why} |" + " |" * 13, flush=True)
                continue
            m, st = res["metrics"], res["metrics"]["methods"]["strain"]
            ours = outline_stats(res["rings"])
            row = (
                f"| {label} | {m['mesh']['vertices']} | {res['wall']:.1f} "
                f"| {sum(st['newton_iterations'])} | {st['total_flipped']} "
                f"| {st['min_area_ratio']:.3f} | {'yes' if m['reached_target'] else 'no'} "
                f"| {st['max_squeeze_excess']:.2f} "
                f"| {ours['crossing']} / {ours['invalid']} | {ours['min']:.2f}–{ours['max']:.2f} "
                f"| {ours['excess']:.2f} "
            )
            if flubber is None:
                print(row + "| no node/npm | | | |", flush=True)
                continue
            ((fl, fl_s),) = _flubber(flubber, [(_shape(a)[0], _shape(b)[0], m["frame_t"])])
            theirs = outline_stats([[f] for f in fl])
            print(
                row + f"| {theirs['crossing']} | {theirs['min']:.2f}–{theirs['max']:.2f} "
                f"| {theirs['excess']:.2f} | {fl_s:.3f} |",
                flush=True,
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--no-flubber", action="store_true")
    ap.add_argument("--budget", type=int, default=200, help="points per shape after simplification")
    ap.add_argument("--no-morph", action="store_true", help="skip table 3 (our morph vs flubber)")
    ap.add_argument("--frames", type=int, default=60, help="frames of table 3 (default 60)")
    ap.add_argument("--only", help="comma-separated pairs SOURCE__TARGET (default: all)")
    ap.add_argument("--pair-timeout", type=float, default=300.0, help="seconds per morph (table 3)")
    ap.add_argument(
        "--with-anchors",
        action="store_true",
        help="table 3 with each pair's committed anchors file (pairs without one left out)",
    )
    args = ap.parse_args()
    chosen = _pairs()
    if args.with_anchors:
        chosen = [p for p in chosen if p[2] is not None]
    if args.only:
        wanted = {p.strip() for p in args.only.split(",") if p.strip()}
        known = {f"{a}__{b}" for a, b, _ in chosen}
        if wanted - known:
            ap.error(f"unknown pair(s) {sorted(wanted - known)}; known: {sorted(known)}")
        chosen = [p for p in chosen if f"{p[0]}__{p[1]}" in wanted]
    rows = []
    print(
        "| pair | pts | pairs (feat+fill) | rot ° | match s | +holes+simplify s | pts after | fixture anchors: median / max dist |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for a, b, fixture in chosen:
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
    if not args.no_flubber:
        _flubber_table(rows)
    if not args.no_morph:
        morph_table(chosen, args.frames, args.pair_timeout, args.no_flubber, args.with_anchors)


def _flubber_table(rows: list[tuple[str, str, np.ndarray, np.ndarray, OutlineMatch]]) -> None:
    """Table 2: flubber and the matched linear outlines at FRAMES even times."""
    with tempfile.TemporaryDirectory(prefix="flubber_") as tmp:
        flubber = _install_flubber(tmp)
        if flubber is None:
            print("\nnode/npm not found: no flubber comparison")
            return
        times = list(np.linspace(0.0, 1.0, FRAMES))
        frames = _flubber(flubber, [(r[2], r[3], times) for r in rows])
    print(
        f"\nOuter rings, {FRAMES} frames at even t: self-intersecting frames, area / source (min-max)\n"
    )
    print(
        "| pair | flubber: bad frames | flubber: area ratio | matched linear: bad | matched linear: area ratio |"
    )
    print("|---|---|---|---|---|")
    for (a, b, src, tgt, m), (fl, _) in zip(rows, frames, strict=True):
        area = abs(Polygon(src).area)
        fb, flo, fhi = _frame_stats(fl, area)
        ob, olo, ohi = _matched_linear_stats(m, src, tgt, area)
        print(f"| {a} → {b} | {fb} | {flo:.2f}-{fhi:.2f} | {ob} | {olo:.2f}-{ohi:.2f} |")


def _matched_linear_stats(
    m: OutlineMatch, src: np.ndarray, tgt: np.ndarray, area: float
) -> tuple[int, float, float]:
    return _frame_stats(_matched_linear(m, src, tgt), area)


if __name__ == "__main__":
    main()
