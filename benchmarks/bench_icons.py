"""Benchmark on random icon pairs against the peers (issue 28): ours, flubber, GSAP MorphSVG,
polymorph-js.

Run:  .venv/bin/python benchmarks/bench_icons.py [--split report|tuning] [--per-category 25]
          [--npm-dir DIR] [--timeout 120] [--no-peers] [--no-ours] [--json OUT.json]

Pairs: :mod:`icon_corpus` (100 report pairs: 25 per category ``outline``, ``holes``,
``parts``, ``strokes``, drawn with the report seed fixed before any pair was looked at;
``--split tuning`` gives the tuning pairs, disjoint from them). The npm packages of
``benchmarks/package.json`` are installed into ``--npm-dir`` (default a folder in the
system's temporary directory) when missing there.

Ours, per pair, as a user runs it: ``conformorph morph2d A.svg B.svg -o OUT`` (every
option at its default, 60 frames), a fresh process timed end to end (Python start-up
included), capped at ``--timeout``. Recorded: exit code and, when not 0, the reason (its
last stderr line); from ``metrics.json`` the flipped triangle-frames; from
``frames.json`` every frame's rings (each part's outline and holes) and so the
*crossing frames*: frames where a ring is not simple or two rings intersect (a part
crossing itself, a hole crossing its outline, or two parts overlapping); and the
*outline squeeze*: the largest excursion of the filled area over frame 0's outside
[1, last frame's] (0 = the area moves monotonically between the two shapes' areas).

Peers, in headless Chromium (``/usr/bin/chromium`` through Playwright; helper
``benchmarks/icon_peers.js``), each with its defaults on the icon's whole path data (all
elements converted to paths by MorphSVGPlugin, joined): ``flubber.interpolate(a, b)``
(0.4.2), ``gsap.to(path, {morphSVG: b})`` (GSAP 3.15.0) and
``polymorph.interpolate([a, b])`` (polymorph-js 1.0.2), sampled at the same 60 times;
each with its defaults except flubber's ``maxSegmentLength`` (the icon's size / 48, not
10 units) and polymorph's ``precision`` (3 decimals, not 0), whose defaults suit drawings
of a few hundred units and would coarsen a 24-unit icon (see icon_peers.js).
Their frames' sub-paths are flattened (svgelements) and checked the same way: closed
sub-paths as rings, open ones (stroke icons) only for crossing themselves. A peer
whose input frames (t = 0 and 1) already cross (overlapping sub-paths in the icon
itself) is counted apart. Peers' seconds are inside the browser, not a process.

Prints one row per pair and a summary: pairs with exit 0, 0 flips and 0 crossing
frames; median and max seconds; failures with their reasons; each peer's pairs with
crossing frames. Timings depend on the machine's load: say it when quoting them.

Measured on main (December 2026, stop 34; quiet 2-CPU machine, load 0.8-1.1), ours only
(``--split report --no-peers``): 53 of 100 clean (outline 19, holes 5, parts 12, strokes
17 of 25), 79 exit 0, whole process median 2.92 s and max 34.9 s; of the 47 others, 21
exit 1 or 2 (mostly the strain morph stalling on a compatible mesh stretched 36-53,000
fold, then hole cuts) and 26 exit 0 with crossing frames (a shrinking or growing part over
a morphing pair). Again on 7 December 2026 (stop 37, a faster spell, load 1-2): 53 of
100 clean (outline 20, holes 4, parts 12, strokes 17), 80 exit 0, median 2.97 s, max 41.3 s;
the tuning split then: 49 clean, holes 3 of 25 (their hole cuts stretch the compatible
meshes 40-1,000 fold and no strain scheme reaches the target). ARAP frames (the metrics'
baseline) on the meshes of the 17 tuning pairs that exit 1 flip triangles on 16 of them:
no fallback for the strain morph. On 7 December 2026 (stop 38, b6b4760; load about 1.5, this machine some 1.5-2x slower
than on stop 37's day: the ICT face morph took 3.4 s where it took 1.8 s), after the
part-separation search was allowed to separate every pair, growing parts were made to
wait outside what shrinking parts sweep, and a one-part pair without anchors that the
strain steps cannot morph falls back to shrinking and growing: 91 of 100 clean
(outline 23, holes 18, parts 25, strokes 25), 100 exit 0, median 7.93 s, max 79.2 s;
of the 91, 49 morph no matched pair (the shapes shrink and grow as wholes) and 55 have a
pair that fell back; the 9 others all exit 0 with crossing frames (1-60). On 8 December
2026 (stop 39, b25d347; quiet apart from the benchmark), after a one-part strain path
whose outline crosses itself falls back too, parts that still cross shrink towards one
point left of every part and grow from one right of them, touching rings and parts are
parted by a hair, and eq. (3) is no fallback without anchors: 99 of 100 clean (outline
25, holes 24, parts 25, strokes 25), 100 exit 0, median 6.76 s, max 75.6 s; of the 99,
56 morph no matched pair and 63 have a pair that fell back; outline squeeze median
0.78 (the dissolves take the area near 0); the one left: livejournal -> librarything, 1
crossing frame. Earlier, on branch ``lottie`` (the hand-written SVG parser, before the svgelements one;
2 CPUs at load average 11-17, so seconds are high): ours 3 of 100 clean (all three exit 0
with 0 flips, 0 crossing frames, area squeeze <= 0.005), 97 refused with exit 2 (84 "SVG
arcs (A) are not supported", 4 "hole 1 lies outside the outer ring", 3 "no closed ring",
6 others: self-crossing rings, nested holes, flipped triangles left, no <path>); every process 2.2-3.7 s when refused, the clean ones
4.2-5.1 s and 39-75 s (elegoo -> heliumbrowser). Peers: flubber ran on 89 (11 refused
the path data), 45 with crossing frames (27 of the 71 whose ends do not cross), area
squeeze median 0.38; GSAP MorphSVG ran on 100, 86 with crossing frames (68 of 82), median
squeeze 0.06; polymorph-js gave NaN coordinates on 56, 42 of the other 44 cross (33 of 35).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from icon_corpus import CATEGORIES, IconPair, icon_pairs

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
FRAMES = 60
PEERS = ("flubber", "gsap", "polymorph")
PEER_SCRIPTS = (
    "flubber/build/flubber.min.js",
    "gsap/dist/gsap.min.js",
    "gsap/dist/MorphSVGPlugin.min.js",
    "polymorph-js/dist/polymorph.min.js",
)


def install(npm_dir: Path) -> None:
    """``npm install`` of benchmarks/package.json into ``npm_dir`` unless already there."""
    wanted = json.loads((HERE / "package.json").read_text())["dependencies"]
    have = npm_dir / "node_modules"
    if all((have / name / "package.json").is_file() for name in wanted):
        return
    npm = shutil.which("npm")
    if npm is None:
        sys.exit("npm is needed to install the icon sets and the peers")
    npm_dir.mkdir(parents=True, exist_ok=True)
    shutil.copy(HERE / "package.json", npm_dir / "package.json")
    subprocess.run([npm, "install", "--no-audit", "--no-fund"], cwd=npm_dir, check=True)


def rings_of(d: str) -> list[tuple[np.ndarray, bool]]:
    """Each sub-path of path data ``d`` flattened: (points (n, 2), closed)."""
    import svgelements as se

    if "nan" in d.lower():
        raise ValueError("NaN coordinates")
    out = []
    for sub in se.Path(d).as_subpaths():
        pts: list[list[float]] = []
        closed = False
        for seg in sub:
            if isinstance(seg, se.Move):
                pts.append([seg.end.x, seg.end.y])
            elif isinstance(seg, se.Close):
                closed = True
            else:
                pts.extend(np.asarray(seg.npoint(np.linspace(0, 1, 9)))[1:].tolist())
        arr = np.array(pts, dtype=float).reshape(-1, 2)
        if len(arr) < 2:
            continue
        closed = closed or bool(np.allclose(arr[0], arr[-1], rtol=0, atol=1e-9))
        keep = np.r_[True, np.any(np.abs(np.diff(arr, axis=0)) > 1e-12, axis=1)]
        arr = arr[keep]
        if closed and len(arr) > 1 and np.allclose(arr[0], arr[-1], rtol=0, atol=1e-12):
            arr = arr[:-1]
        if len(arr) >= 2:
            out.append((arr, closed))
    return out


def frame_crosses(rings: list[tuple[np.ndarray, bool]]) -> bool:
    """Whether a ring crosses itself or another ring, or an open sub-path crosses itself."""
    import shapely
    from shapely.geometry import LinearRing, LineString

    closed = [LinearRing(r) for r, c in rings if c and len(r) >= 3]
    opened = [LineString(r) for r, c in rings if not c]
    if not all(g.is_simple for g in closed + opened):
        return True
    if len(closed) < 2:
        return False
    tree = shapely.STRtree(closed)
    i, j = tree.query(closed, predicate="intersects")
    return bool(np.any(i < j))


def filled_area(rings: list[tuple[np.ndarray, bool]]) -> float:
    """Area filled by the closed rings under the even-odd rule."""
    from shapely.geometry import Polygon
    from shapely.validation import make_valid

    region = None
    for r, c in rings:
        if c and len(r) >= 3:
            p = make_valid(Polygon(r))
            region = p if region is None else region.symmetric_difference(p)
    return 0.0 if region is None else float(region.area)


def squeeze(areas: list[float]) -> float | None:
    """Largest excursion of area / frame 0's outside [1, last frame's] (None: no area)."""
    a = np.asarray(areas)
    if len(a) == 0 or a[0] <= 0:
        return None
    r = a / a[0]
    lo, hi = min(1.0, r[-1]), max(1.0, r[-1])
    return max(0.0, float(np.max((lo - r) / max(lo, 1e-300))), float(np.max((r - hi) / hi)))


def parts_overlap(parts: list[list[np.ndarray]]) -> bool:
    """Whether the parts (each its outline, then its holes) are not a valid MultiPolygon:
    one part inside or over another, or a hole outside its outline."""
    from shapely.geometry import MultiPolygon, Polygon

    polys = [Polygon(rings[0], rings[1:]) for rings in parts]
    return not MultiPolygon(polys).is_valid


def frames_stats(
    frames: list[list[tuple[np.ndarray, bool]]], parts: list[list[list[np.ndarray]]] | None = None
) -> dict[str, Any]:
    """Crossing frames (all, and whether the two ends cross) and the outline squeeze; with
    ``parts`` (ours), a frame whose parts overlap or nest counts as crossing too."""
    crossing = [frame_crosses(f) for f in frames]
    if parts is not None:
        crossing = [c or parts_overlap(p) for c, p in zip(crossing, parts, strict=True)]
    return {
        "crossing_frames": int(sum(crossing)),
        "ends_cross": bool(crossing[0] or crossing[-1]),
        "squeeze": squeeze([filled_area(f) for f in frames]),
    }


def run_ours(pair: IconPair, out: Path, timeout: float) -> dict[str, Any]:
    """``conformorph morph2d A.svg B.svg -o OUT`` as a fresh process, timed, and its frames."""
    cmd = [sys.executable, "-m", "conformorph.cli", "morph2d"]
    cmd += [str(pair.source), str(pair.target), "-o", str(out), "--quiet"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return {"rc": None, "seconds": timeout, "reason": f"timeout after {timeout:g} s"}
    row: dict[str, Any] = {"rc": done.returncode, "seconds": time.perf_counter() - t0}
    lines = [x for x in done.stderr.strip().splitlines() if x.strip()]
    if done.returncode != 0:
        row["reason"] = lines[-1] if lines else f"exit {done.returncode}"
    if (out / "metrics.json").is_file() and (out / "frames.json").is_file():
        m = json.loads((out / "metrics.json").read_text())
        row["flips"] = int(m["methods"]["strain"]["total_flipped"])
        pairs = (m.get("parts") or {}).get("pairs", [])
        # no matched pair morphs: every part shrinks into a point or grows out of one
        row["dissolved"] = bool(m.get("parts")) and all(p["separated"] for p in pairs)
        row["fallback_pairs"] = sum("fallback" in p for p in pairs)
        doc = json.loads((out / "frames.json").read_text())
        frames, parts = [], []
        for fr in doc["frames"]:
            paths = fr.get("parts") or [{"outline": fr["outline"], "holes": fr["holes"]}]
            rings = [[rings_of(d)[0] for d in [p["outline"], *p["holes"]]] for p in paths]
            frames.append([r for part in rings for r in part])
            parts.append([[r for r, _ in part] for part in rings])
        row.update(frames_stats(frames, parts))
    return row


def run_peers(pairs: list[IconPair], npm_dir: Path) -> list[dict[str, Any]]:
    """Each peer on each pair in one headless Chromium page (see icon_peers.js)."""
    from playwright.sync_api import sync_playwright

    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(
            executable_path="/usr/bin/chromium",
            args=["--headless", "--no-sandbox", "--disable-gpu"],
        )
        try:
            page = browser.new_page()
            page.set_content("<!doctype html><body></body>")
            for script in PEER_SCRIPTS:
                page.add_script_tag(path=str(npm_dir / "node_modules" / script))
            page.add_script_tag(path=str(HERE / "icon_peers.js"))
            for pair in pairs:
                a = page.evaluate("s => iconPeers.pathData(s)", pair.source.read_text())
                b = page.evaluate("s => iconPeers.pathData(s)", pair.target.read_text())
                size = page.evaluate("s => iconPeers.size(s)", pair.source.read_text())
                res = page.evaluate(
                    "([a, b, n, s]) => iconPeers.run(a, b, n, s)", [a, b, FRAMES, size]
                )
                row = {}
                for peer in PEERS:
                    r = res[peer]
                    error = (r["error"] or "").strip().splitlines()[:1]
                    entry: dict[str, Any] = {
                        "ok": r["ok"],
                        "error": error[0] if error else None,
                        "seconds": r["seconds"],
                    }
                    if r["ok"]:
                        try:
                            entry.update(frames_stats([rings_of(d) for d in r["frames"]]))
                        except Exception as exc:  # unreadable output is the peer's failure
                            entry.update(ok=False, error=f"unreadable frames: {exc}")
                    row[peer] = entry
                rows.append(row)
        finally:
            browser.close()
    return rows


def _cell(r: dict[str, Any] | None) -> str:
    if r is None:
        return "-"
    if "crossing_frames" not in r:
        return "fail"
    sq = r.get("squeeze")
    end = "*" if r.get("ends_cross") else ""
    return f"{r['crossing_frames']}{end} / {'-' if sq is None else f'{sq:.2f}'}"


def print_report(
    pairs: list[IconPair], ours: list[dict[str, Any] | None], peers: list[dict[str, Any]] | None
) -> None:
    """The table (one row per pair) and the summary."""
    print(
        "\n| # | category | pair | ours: exit | s | flips | crossing / squeeze |"
        + "".join(f" {p}: crossing / squeeze |" for p in PEERS)
    )
    print("|---" * (7 + len(PEERS)) + "|")
    for k, pair in enumerate(pairs):
        o = ours[k]
        head = f"| {k + 1} | {pair.category} | {pair.name} |"
        if o is None:
            head += " - | - | - | - |"
        else:
            head += f" {o['rc']} | {o['seconds']:.2f} | {o.get('flips', '-')} | {_cell(o)} |"
        print(head + "".join(f" {_cell(peers[k][p]) if peers else '-'} |" for p in PEERS))
    print(
        "\n(crossing = frames of 60 with a ring crossing itself or another; * = the peer's input"
        " frames already cross; squeeze = area excursion outside [1, last/first])"
    )
    print_summary(pairs, ours, peers)


def print_summary(
    pairs: list[IconPair], ours: list[dict[str, Any] | None], peers: list[dict[str, Any]] | None
) -> None:
    n = len(pairs)
    if any(o is not None for o in ours):
        done = [o for o in ours if o is not None]
        clean = [
            o
            for o in done
            if o["rc"] == 0 and o.get("flips") == 0 and o.get("crossing_frames") == 0
        ]
        secs = [o["seconds"] for o in done]
        print(
            f"\nours: {len(clean)} of {n} pairs exit 0 with 0 flips and 0 crossing frames; "
            f"exit 0: {sum(o['rc'] == 0 for o in done)}; seconds (whole process, every pair) "
            f"median {statistics.median(secs):.2f}, max {max(secs):.2f}"
        )
        dissolved = [o for o in clean if o.get("dissolved")]
        print(
            f"  of the clean pairs, {len(dissolved)} morph no matched pair (every part shrinks"
            f" into a point or grows out of one); {sum(o.get('fallback_pairs', 0) > 0 for o in clean)}"
            " have a pair the strain morph could not do, shrunk and grown instead"
        )
        ok_secs = [o["seconds"] for o in done if o["rc"] == 0]
        if ok_secs:
            print(
                f"  exit-0 pairs: median {statistics.median(ok_secs):.2f} s, max {max(ok_secs):.2f} s"
            )
        for cat in CATEGORIES:
            rows = [
                o for p, o in zip(pairs, ours, strict=True) if p.category == cat and o is not None
            ]
            good = sum(o in clean for o in rows)
            print(f"  {cat}: {good} of {len(rows)} clean")
        squeezes = [o["squeeze"] for o in done if o["rc"] == 0 and o.get("squeeze") is not None]
        if squeezes:
            print(
                f"  outline squeeze (exit-0 pairs): median {statistics.median(squeezes):.3f}, "
                f"max {max(squeezes):.3f}"
            )
        reasons = Counter(o.get("reason", "") for o in done if o["rc"] != 0)
        for why, count in reasons.most_common():
            print(f"  failed x{count}: {why}")
        unclean = [
            (p.name, o)
            for p, o in zip(pairs, ours, strict=True)
            if o and o["rc"] == 0 and o not in clean
        ]
        for name, o in unclean:
            print(
                f"  exit 0 but flips {o.get('flips')} / crossing frames {o.get('crossing_frames')}: {name}"
            )
    if peers:
        for peer in PEERS:
            rs = [r[peer] for r in peers]
            ok = [r for r in rs if r["ok"]]
            crossing = [r for r in ok if r["crossing_frames"] > 0]
            clean_in = [r for r in ok if not r["ends_cross"]]
            crossing_in = [r for r in clean_in if r["crossing_frames"] > 0]
            errs = Counter(r["error"] for r in rs if not r["ok"])
            sq = [r["squeeze"] for r in ok if r.get("squeeze") is not None]
            secs = [r["seconds"] for r in ok]
            print(
                f"\n{peer}: ran on {len(ok)} of {n}; pairs with crossing frames {len(crossing)} "
                f"(of the {len(clean_in)} whose own ends do not cross: {len(crossing_in)}); "
                f"crossing frames in all {sum(r['crossing_frames'] for r in ok)}; outline squeeze "
                f"median {statistics.median(sq) if sq else float('nan'):.3f}; seconds in the "
                f"browser median {statistics.median(secs) if secs else float('nan'):.4f}"
            )
            for why, count in errs.most_common(5):
                print(f"  failed x{count}: {why}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--split", choices=["report", "tuning"], default="report")
    ap.add_argument("--per-category", type=int, default=25)
    ap.add_argument(
        "--npm-dir", type=Path, default=Path(tempfile.gettempdir()) / "conformorph-bench-icons"
    )
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--no-ours", action="store_true")
    ap.add_argument("--json", type=Path, default=None, help="also write every row as JSON")
    args = ap.parse_args()
    install(args.npm_dir)
    pairs = icon_pairs(args.npm_dir, args.split, args.per_category)
    print(
        f"{len(pairs)} {args.split} pairs; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    ours: list[dict[str, Any] | None] = [None] * len(pairs)
    if not args.no_ours:
        with tempfile.TemporaryDirectory(prefix="bench-icons-") as tmp:
            for k, pair in enumerate(pairs):
                ours[k] = run_ours(pair, Path(tmp) / f"{k:03d}", args.timeout)
                print(
                    f"  {k + 1}/{len(pairs)} {pair.name}: exit {ours[k]['rc']}, "  # type: ignore[index]
                    f"{ours[k]['seconds']:.1f} s",
                    file=sys.stderr,
                    flush=True,
                )  # type: ignore[index]
    peers = None if args.no_peers else run_peers(pairs, args.npm_dir)
    print_report(pairs, ours, peers)
    if args.json:
        rows = [
            {
                "pair": p.name,
                "category": p.category,
                "ours": o,
                "peers": None if peers is None else peers[k],
            }
            for k, (p, o) in enumerate(zip(pairs, ours, strict=True))
        ]
        args.json.write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
