"""Whole ``conformorph morph`` runs on face pairs from 7k to 1M vertices: wall time and peak memory.

Run::

    .venv/bin/python benchmarks/bench_scan_scale.py [--sizes 7k,17k,68k,270k,1M]
        [--vertex-budget N] [--cache cold,warm,off] [--morph-arg=FLAG ...] [--workdir DIR]
        [--json]
    .venv/bin/python benchmarks/bench_scan_scale.py --budgets 15000,25000,50000,100000,0
        [--sizes 68k,270k] [--workdir DIR] [--json]

``--budgets`` compares working resolutions instead (``0``: none, the mesh as read): per
size and budget, one process runs stage 1 to the frames as ``conformorph morph
--vertex-budget B --frame-times 0.25,0.5,0.75`` does (:func:`budget_child`; no metrics,
no export) and prints the frames' error against the truth, the blend ``A + t (B - A)``
of the two keys at full resolution (the pair's vertices correspond one to one): ``L2`` of
:func:`conformorph.geometry.surface_distance.surface_to_surface_error`, relative to the
diagonal, the largest over the three times; with its wall time, peak memory and the
prepared vertex counts. A failing run is a row with its error message.

Each size is a pair of faces morphed by ``conformorph morph A B --landmarks L.json -o OUT
--json`` as its own process with default settings (``--prepare auto``, the default vertex
budget; ``--vertex-budget N`` is passed on when given; ``--morph-arg=FLAG`` adds a flag), in
each key-cache state of ``--cache`` (default ``cold,warm``: an empty cache folder of its own,
then one a first unmeasured run filled; ``off``: ``--no-cache``; never the user's cache):

- ``7k``: ``ict_generic_neutral`` → ``ict_generic_smile`` with the shared 68 landmarks;
- ``17k``: ``choi_human_face`` and a smooth deformation of it (every vertex moved by
  ``0.03 d sin(3π (x - c) / d)`` with the coordinates rotated, ``d`` the diagonal);
- ``68k``, ``270k``, ``1M``: the same pair after 1, 2 and 3 midpoint subdivisions
  (68,457, 273,489 and 1,093,281 vertices; the deformation is applied after subdividing);

the choi pairs with 30 random interior landmarks (seed 0) of the 17k mesh, whose vertex
ids every subdivision keeps. Measured per size: the wall time of the process, its peak
memory (the largest sum of the resident set sizes of the process and its children,
sampled every 50 ms with psutil), its CPU seconds (user + system: what an unloaded
2-core machine would take at least, the pipeline being mostly single-threaded), the
stage seconds of ``metrics.json`` and the output's
vertex count, with the load average before the run (the machine is shared: read times
as ratios). Targets (issue 17): the 270k pair in at most 40 s and 3 GB, the 1M pair
(prepared to the budget) in at most 60 s and 4 GB; written at the input resolution
(``--morph-arg=--output-resolution=input``, issue 29), the 1M pair in at most 60 s with a
GLB of at most 120 MB (the GLB's size is printed for every run). Needs
``../shared/data/faces``; the input files are written to ``--workdir`` (default a temporary
folder; 250 MB for 1M).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FACES = ROOT.parent / "shared" / "data" / "faces"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

SIZES = ("7k", "17k", "68k", "270k", "1M")
LEVELS = {"17k": 0, "68k": 1, "270k": 2, "1M": 3}
TARGETS = {"270k": (40.0, 3.0), "1M": (60.0, 4.0)}  # seconds, GB (issue 17: the default path)
#: Written at the input resolution (``--output-resolution input``), issue 29: seconds, GLB MB
FULL_RESOLUTION_TARGETS = {"1M": (60.0, 120.0)}


def deformed(V: np.ndarray) -> np.ndarray:
    """The smooth deformation of the second key (3 % of the diagonal at most)."""
    d = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    c = V.mean(axis=0)
    return V + 0.03 * d * np.sin(3.0 * np.pi * (V - c) / d)[:, [1, 2, 0]]


def interior_landmarks(V: np.ndarray, F: np.ndarray, k: int = 30, seed: int = 0) -> list[int]:
    """``k`` random vertex ids away from the boundary (within 30 % of the diagonal of the
    centre, in the x-y plane)."""
    from conformorph.geometry import mesh_edges

    boundary = np.unique(mesh_edges(F).boundary)
    d = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    near = np.linalg.norm(V[:, :2] - V.mean(axis=0)[:2], axis=1) < 0.3 * d
    near[boundary] = False
    rng = np.random.default_rng(seed)
    return sorted(int(i) for i in rng.choice(np.flatnonzero(near), size=k, replace=False))


def make_inputs(size: str, work: Path) -> tuple[list[Path], Path]:
    """The pair's two OBJ files and landmark file (written once per ``work`` folder)."""
    from benchmarks.bench_face_tables import subdivide
    from conformorph.pipelines.mesh_io import read_mesh, write_obj

    lm_path = work / f"{size}_landmarks.json"
    if size == "7k":
        lm = json.loads((FACES / "ict_landmarks68.json").read_text())
        lm_path.write_text(json.dumps({"landmarks": [lm["landmarks_multipie68_0based"]] * 2}))
        return [FACES / "ict_generic_neutral.obj", FACES / "ict_generic_smile.obj"], lm_path
    paths = [work / f"{size}_{i}.obj" for i in range(2)]
    V, F = read_mesh(FACES / "choi_human_face.obj")
    lm_ids = interior_landmarks(V, F)
    lm_path.write_text(json.dumps({"landmarks": [lm_ids, lm_ids]}))
    if not all(p.exists() for p in paths):
        for _ in range(LEVELS[size]):
            V, F = subdivide(V, F)
        write_obj(paths[0], V, F)
        write_obj(paths[1], deformed(V), F)
    return paths, lm_path


def run_measured(argv: list[str]) -> tuple[float, float, int, int, str]:
    """Wall seconds, CPU seconds (user + system), peak resident bytes of the process
    tree, exit code, stdout."""
    import resource

    import psutil

    before = resource.getrusage(resource.RUSAGE_CHILDREN)

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    ps = psutil.Process(proc.pid)
    peak = 0
    out_chunks: list[bytes] = []
    while proc.poll() is None:
        try:
            rss = ps.memory_info().rss + sum(
                c.memory_info().rss for c in ps.children(recursive=True)
            )
            peak = max(peak, rss)
        except psutil.Error:
            pass
        time.sleep(0.05)
    seconds = time.perf_counter() - t0
    out, err = proc.communicate()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    out_chunks.append(out)
    if proc.returncode:
        sys.stderr.write(err.decode(errors="replace")[-2000:])
    return seconds, cpu, peak, int(proc.returncode), b"".join(out_chunks).decode()


def measured_row(argv: list[str], fields: dict[str, Any]) -> tuple[dict[str, Any], str]:
    """Run ``argv`` measured (:func:`run_measured`); the row ``fields`` plus the load
    average before, wall and CPU seconds, peak memory and exit code, and the stdout."""
    load = os.getloadavg()
    seconds, cpu, peak, code, out = run_measured(argv)
    row: dict[str, Any] = {
        **fields,
        "load_average": [round(x, 2) for x in load],
        "seconds": round(seconds, 2),
        "cpu_seconds": round(cpu, 2),
        "peak_gb": round(peak / 1e9, 3),
        "exit_code": code,
    }
    return row, out


CACHE_MODES = ("cold", "warm", "off")


def bench_size(
    size: str, work: Path, budget: int | None, cache: str = "cold", extra: tuple[str, ...] = ()
) -> dict[str, Any]:
    """One pair morphed as ``conformorph morph`` runs it; the figures of the run.

    ``cache``: ``cold`` (an empty key cache), ``warm`` (the cache a first, unmeasured run of
    the same command filled) or ``off`` (``--no-cache``); never the user's own cache, which
    an earlier run may have filled. ``extra``: further ``morph`` flags."""
    paths, lm_path = make_inputs(size, work)
    out_dir = work / f"out_{size}"
    argv = [sys.executable, "-m", "conformorph.cli", "morph", *map(str, paths)]
    argv += ["--landmarks", str(lm_path), "-o", str(out_dir), "--json", "--quiet", *extra]
    if budget is not None:
        argv += ["--vertex-budget", str(budget)]
    folder = work / f"key-cache-{size}-{cache}"
    if folder.exists():
        import shutil

        shutil.rmtree(folder)
    argv += ["--no-cache"] if cache == "off" else ["--cache", str(folder)]
    if cache == "warm":  # the first run fills the cache; the measured one reads it
        subprocess.run(argv, capture_output=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    row, out = measured_row(argv, {"size": size, "cache": cache, "flags": list(extra)})
    code = row["exit_code"]
    if code == 0:
        metrics = json.loads(out)
        row["key_cache"] = [i.get("cache", {}).get("state", "off") for i in metrics["inputs"]]
        row["output_resolution"] = metrics.get("output_resolution", {}).get("output_resolution")
        row["stages"] = {k: round(v, 2) for k, v in metrics["seconds"].items()}
        row["inputs"] = [
            {
                "vertices": (i.get("preparation") or {}).get("input", {}).get("vertices"),
                "prepared": (i.get("preparation") or {}).get("output", {}).get("vertices"),
                "decimated": bool((i.get("preparation") or {}).get("decimation")),
            }
            for i in metrics.get("inputs", [])
        ]
    glb = out_dir / "animation.glb"
    row["glb_mb"] = round(glb.stat().st_size / 1e6, 1) if code == 0 and glb.exists() else None
    if row.get("output_resolution") == "input" and size in FULL_RESOLUTION_TARGETS:
        s_max, mb_max = FULL_RESOLUTION_TARGETS[size]
        row["target"] = f"≤{s_max:.0f} s, GLB ≤{mb_max:.0f} MB (full resolution)"
        row["meets_target"] = bool(
            code == 0 and row["seconds"] <= s_max and (row["glb_mb"] or 0.0) <= mb_max
        )
    elif size in TARGETS:
        s_max, gb_max = TARGETS[size]
        row["target"] = f"≤{s_max:.0f} s, ≤{gb_max:.0f} GB"
        row["meets_target"] = bool(
            code == 0 and row["seconds"] <= s_max and row["peak_gb"] <= gb_max
        )
    return row


BUDGET_TIMES = (0.25, 0.5, 0.75)


def budget_child(size: str, work: Path, budget: int) -> None:
    """Stage 1 to the frames of one pair at one vertex budget (0: none), in this process;
    prints one JSON line: the frames' error against the truth and the prepared counts."""
    from benchmarks.bench_scan_inputs import morph_frames
    from conformorph.geometry.surface_distance import surface_to_surface_error
    from conformorph.pipelines.mesh_io import read_mesh

    paths, lm_path = make_inputs(size, work)
    out: dict[str, Any] = {}
    try:
        Vf, Ff, meta = morph_frames(paths, lm_path, ["--vertex-budget", str(budget)])
    except Exception as exc:  # noqa: BLE001 - a failure is a result here
        import traceback

        where = [
            f"{f.name} ({Path(f.filename).name}:{f.lineno})"
            for f in traceback.extract_tb(exc.__traceback__)
        ]
        print(json.dumps({"error": f"{type(exc).__name__}: {exc}", "where": where[-6:]}))
        return
    A, F = read_mesh(paths[0])
    B, _ = read_mesh(paths[1])
    out["errors"] = [
        surface_to_surface_error(Vf[k], Ff, A + t * (B - A), F)["L2"]
        for k, t in enumerate(BUDGET_TIMES)
    ]
    out["prepared_vertices"] = [
        (p.get("output") or {}).get("vertices") for p in meta["preparation"]
    ]
    out["passes"] = [(p.get("decimation") or {}).get("passes") for p in meta["preparation"]]
    print(json.dumps(out))


def bench_budget(size: str, work: Path, budget: int) -> dict[str, Any]:
    """One :func:`budget_child` run measured as its own process."""
    make_inputs(size, work)  # written once, before the timing
    argv = [sys.executable, str(Path(__file__).resolve()), "--budget-child"]
    argv += [f"{size}:{budget}", "--workdir", str(work)]
    row, out = measured_row(argv, {"size": size, "budget": budget})
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    if lines:
        row.update(json.loads(lines[-1]))
    if "errors" in row:
        row["max_error"] = max(row["errors"])
    return row


def main_budgets(sizes: list[str], budgets: list[int], work: Path) -> list[dict[str, Any]]:
    """Every size at every budget: the rows, printed as they come."""
    rows = []
    for size in sizes:
        for budget in budgets:
            row = bench_budget(size, work, budget)
            rows.append(row)
            what = (
                f"max frame error {row['max_error']:.3g} (per time "
                f"{[float(f'{e:.3g}') for e in row['errors']]}), prepared "
                f"{row['prepared_vertices']}, passes {row['passes']}"
                if "max_error" in row
                else f"FAILED {row.get('error', 'exit ' + str(row['exit_code']))}"
            )
            print(
                f"{size} budget {budget or 'none'}: {row['seconds']:.1f} s (CPU "
                f"{row['cpu_seconds']:.1f} s), peak {row['peak_gb']:.2f} GB, {what} "
                f"(load {row['load_average']})",
                flush=True,
            )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default=None)
    ap.add_argument("--vertex-budget", type=int, default=None)
    ap.add_argument("--budgets", default=None, help="compare these budgets (0: none)")
    ap.add_argument("--budget-child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--workdir", default=None)
    ap.add_argument("--json", action="store_true")
    ap.add_argument(
        "--cache",
        default="cold,warm",
        help="key-cache states to measure each size in, comma-separated: cold (empty), warm "
        "(filled by an unmeasured first run), off (--no-cache); default cold,warm",
    )
    ap.add_argument(
        "--morph-arg",
        action="append",
        default=[],
        help="a further 'conformorph morph' flag (repeatable), e.g. "
        "--morph-arg=--output-resolution --morph-arg=input",
    )
    args = ap.parse_args()
    caches = args.cache.split(",")
    if any(c not in CACHE_MODES for c in caches):
        ap.error(f"--cache takes {', '.join(CACHE_MODES)}")
    if args.budget_child:
        size, budget = args.budget_child.split(":")
        budget_child(size, Path(args.workdir), int(budget))
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.workdir or tmp)
        work.mkdir(parents=True, exist_ok=True)
        if args.budgets:
            sizes = (args.sizes or "68k,270k").split(",")
            rows = main_budgets(sizes, [int(b) for b in args.budgets.split(",")], work)
        runs = [
            (size, cache)
            for size in ((args.sizes or ",".join(SIZES)).split(",") if not args.budgets else [])
            for cache in caches
        ]
        for size, cache in runs:
            row = bench_size(size, work, args.vertex_budget, cache, tuple(args.morph_arg))
            rows.append(row)
            target = ""
            if "meets_target" in row:
                target = f"; target {row['target']}: {'met' if row['meets_target'] else 'MISSED'}"
            print(
                f"{size} {cache} cache {' '.join(args.morph_arg)}: {row['seconds']:.1f} s "
                f"(CPU {row['cpu_seconds']:.1f} s), peak {row['peak_gb']:.2f} GB, exit "
                f"{row['exit_code']}, key cache {row.get('key_cache')}, output "
                f"{row.get('output_resolution')}, GLB {row.get('glb_mb')} MB, stages "
                f"{row.get('stages')}, inputs "
                f"{row.get('inputs')} (load {row['load_average']}){target}",
                flush=True,
            )
    if args.json:
        print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
