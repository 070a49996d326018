"""A quick check of ``conformorph morph2d`` on real icon SVGs (issue 28, the input half).

Run:  .venv/bin/python benchmarks/bench_svg_icons_quick.py --icons DIR [--seed 2028]
          [--per-set 5] [--timeout 300]

``DIR`` is a ``node_modules`` folder holding the npm packages ``lucide-static`` (ISC,
stroked), ``@tabler/icons`` (MIT; outline = stroked, filled), ``heroicons`` (MIT; solid
and outline) and ``simple-icons`` (CC0; filled logos, often several parts), e.g. after
``npm install lucide-static @tabler/icons heroicons simple-icons`` in a scratch folder.

Pairs: the six of the issue's table in lucide (heart → star, cloud → zap, moon → heart,
key → trophy, user → bell, apple → heart), eight more named ones across the sets, and
``--per-set`` random pairs from each of six folders drawn with ``--seed``. This is not
the 100-pair report benchmark against the peers (``benchmarks/bench_icons.py``, the
output half of the issue): it shows which kinds of icon go through and what fails.

Each pair runs as users run it, a fresh process with every option at its default:
``python -m conformorph.cli morph2d A.svg B.svg -o OUT``. Per pair: exit code, wall
seconds, CPU seconds of the process (user + system: on a shared machine the wall time
measures the load as much as the work), and from ``metrics.json`` flipped
triangle-frames, frames where parts overlap or an outline crosses itself, parts of
each shape, stroked elements outlined and pairs that shrank and grew instead of
morphing (``parts.fallback_pairs``). "Clean" = exit 0, 0 flips, 0 overlapping and 0
self-crossing frames. The machine's load average is printed beside the timings.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SETS = [
    "lucide-static/icons",
    "@tabler/icons/icons/outline",
    "@tabler/icons/icons/filled",
    "heroicons/24/solid",
    "heroicons/24/outline",
    "simple-icons/icons",
]
NAMED = [
    ("lucide-static/icons", a, b)
    for a, b in [
        ("heart", "star"), ("cloud", "zap"), ("moon", "heart"),
        ("key", "trophy"), ("user", "bell"), ("apple", "heart"),
    ]
] + [
    ("heroicons/24/solid", "key", "trophy"), ("heroicons/24/solid", "user", "bell"),
    ("heroicons/24/solid", "moon", "heart"), ("heroicons/24/outline", "cloud", "star"),
    ("@tabler/icons/icons/filled", "apple", "heart"),
    ("@tabler/icons/icons/outline", "user", "bell"),
    ("simple-icons/icons", "github", "gitlab"), ("simple-icons/icons", "python", "docker"),
]  # fmt: skip


def pairs(icons: Path, seed: int, per_set: int) -> list[tuple[Path, Path]]:
    """The named pairs, then ``per_set`` random pairs per folder (names sorted, then drawn)."""
    out = [(icons / d / f"{a}.svg", icons / d / f"{b}.svg") for d, a, b in NAMED]
    rng = random.Random(seed)
    for d in SETS:
        names = sorted(p.name for p in (icons / d).glob("*.svg"))
        for _ in range(per_set):
            a, b = rng.sample(names, 2)
            out.append((icons / d / a, icons / d / b))
    return out


def run_pair(a: Path, b: Path, out: Path, timeout: float) -> dict:
    """One whole ``morph2d`` process: exit code, wall and CPU seconds, and its metrics."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "conformorph.cli", "morph2d", str(a), str(b), "-o", str(out)]
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
        rc, err = p.returncode, p.stderr.strip().splitlines()[-1:] or [""]
    except subprocess.TimeoutExpired:
        rc, err = -1, [f"timed out after {timeout:.0f} s"]
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    row = {"rc": rc, "wall": wall, "cpu": cpu, "error": err[0][:160] if rc else ""}
    m_path = out / "metrics.json"
    if m_path.exists():
        m = json.loads(m_path.read_text())
        parts = m.get("parts", {})
        row |= {
            "flips": m["methods"]["strain"]["total_flipped"],
            "overlap": parts.get("overlapping_frames", 0),
            "selfx": parts.get("self_crossing_frames", 0),
            "parts": f"{parts.get('source_parts', 1)}→{parts.get('target_parts', 1)}",
            "strokes": "{source}/{target}".format(**m.get("strokes_outlined", {})),
            "fallback": parts.get("fallback_pairs", 0),
        }
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--icons", type=Path, required=True, help="node_modules with the icon sets")
    ap.add_argument("--seed", type=int, default=2028)
    ap.add_argument("--per-set", type=int, default=5)
    ap.add_argument("--timeout", type=float, default=300.0)
    args = ap.parse_args()
    rows = []
    print(f"load average at start: {os.getloadavg()[0]:.1f} ({os.cpu_count()} CPUs)\n")
    print("| pair | exit | wall s | CPU s | flips | overlap / self-x frames | parts | "
          "strokes | fallback pairs | error |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k, (a, b) in enumerate(pairs(args.icons, args.seed, args.per_set)):
            r = run_pair(a, b, Path(tmp) / str(k), args.timeout)
            rows.append(r)
            name = f"{a.parent.relative_to(args.icons)}: {a.stem} → {b.stem}"
            print(
                f"| {name} | {r['rc']} | {r['wall']:.1f} | {r['cpu']:.1f} | {r.get('flips', '')} "
                f"| {r.get('overlap', '')} / {r.get('selfx', '')} | {r.get('parts', '')} | "
                f"{r.get('strokes', '')} | {r.get('fallback', '')} | {r['error']} |",
                flush=True,
            )
    done = [r for r in rows if r["rc"] == 0]
    clean = [r for r in done if r["flips"] == 0 and r["overlap"] == 0 and r["selfx"] == 0]
    print(f"\n{len(clean)} of {len(rows)} clean; {len(done)} exit 0; "
          f"{sum(1 for r in clean if r['fallback'])} of the clean ones shrank and grew a pair")  # fmt: skip
    if done:
        for key in ("wall", "cpu"):
            v = [r[key] for r in done]
            print(f"{key} s (exit 0): median {statistics.median(v):.2f}, max {max(v):.2f}")
    print(f"load average at end: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
