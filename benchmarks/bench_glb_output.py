"""Size, precision and lighting of the face morph's ``animation.glb`` by output flags.

Run:  .venv/bin/python benchmarks/bench_glb_output.py [--case ict|big]

Each variant is the whole ``conformorph morph`` command (a fresh process, wall time
included) with ``--frames 30 --no-metrics``:

* ``positions only`` — ``--no-normals --compress none``: the content of main's default
  before issue 29 (position deltas as float32);
* ``+ normals`` — ``--compress none``: NORMAL targets, the new default's content;
* ``default`` — normals, ``--compress auto`` (above 16 MiB: ``KHR_mesh_quantization``
  targets under ``EXT_meshopt_compression``);
* ``meshopt`` — ``--compress meshopt``;
* ``working res.`` — ``--output-resolution working``: the decimated working mesh rather
  than key 0 at its input resolution (the default since issue 29; the same file when
  nothing was decimated).

Cases: ``ict`` (ICT generic neutral → smile → jawOpen, 7k vertices, 68 exact landmarks)
and ``big`` (two 68k-vertex faces: ``choi_human_face`` subdivided once, the second
deformed smoothly, 30 landmarks, as ``bench_face_speed.py``). For every variant: file
size, ratio to ``positions only``, the largest distance of any vertex at 61 times from
the uncompressed file's (relative to the bounding-box diagonal), and the 95th
percentile angle between the normals a viewer lights with (base NORMAL plus weighted
deltas) and those of the frame's true positions (the uncompressed file's when the vertex
count is the same: a quantized file's own positions carry its rounding, which tilts the
normals of small triangles), worst over the frames; the Khronos
validator's errors/warnings (``tools/gltf_validate.mjs``, when node and the npm package are
there).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from benchmarks.bench_face_tables import subdivide  # noqa: E402
from conformorph.geometry.static_correspondences import farthest_point_samples  # noqa: E402
from conformorph.geometry.vertex_normals import vertex_normals  # noqa: E402
from conformorph.pipelines.mesh_io import read_mesh, write_obj  # noqa: E402
from tests.pipelines.glb_playback import MorphGlb  # noqa: E402

#: ../shared/data/faces beside the checkout, or $CONFORMORPH_SHARED_DATA/faces
FACES = Path(os.environ.get("CONFORMORPH_SHARED_DATA") or ROOT.parent / "shared" / "data") / "faces"
VARIANTS = {
    "positions only": ["--no-normals", "--compress", "none"],
    "+ normals": ["--compress", "none"],
    "default": [],
    "meshopt": ["--compress", "meshopt"],
    "working res.": ["--output-resolution", "working"],
}


def ict_inputs(d: Path) -> tuple[list[Path], Path]:
    lm = json.loads((FACES / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    L = d / "ict.json"
    L.write_text(json.dumps({"landmarks": [lm] * 3}))
    names = ("neutral", "smile", "jawOpen")
    return [FACES / f"ict_generic_{n}.obj" for n in names], L


def big_inputs(d: Path) -> tuple[list[Path], Path]:
    V, F = read_mesh(FACES / "choi_human_face.obj")
    V, F = subdivide(V, F)
    c = V.mean(axis=0)
    diam = np.linalg.norm(V.max(0) - V.min(0))
    V2 = V + 0.03 * diam * np.sin(3 * (V - c) / diam)[:, [1, 2, 0]]
    write_obj(d / "a.obj", V, F)
    write_obj(d / "b.obj", V2, F)
    inner = np.flatnonzero(np.linalg.norm(V[:, :2] - c[:2], axis=1) < 0.3 * diam)
    ids = farthest_point_samples(V, 30, candidates=inner).tolist()
    L = d / "big.json"
    L.write_text(json.dumps({"landmarks": [ids, ids]}))
    return [d / "a.obj", d / "b.obj"], L


def lighting_p95(m: MorphGlb, times: np.ndarray, ref: MorphGlb | None = None) -> float:
    """Worst 95th-percentile angle (degrees) between viewer and true normals (those of
    ``ref``'s positions, else of ``m``'s own)."""
    if m.base_N is None:
        return float("nan")
    worst = 0.0
    for t in times:
        P = (m if ref is None else ref).positions(float(t))
        N = vertex_normals(P, m.F)
        N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)
        cos = np.clip(np.sum(m.shader_normals(float(t)) * N, axis=1), -1.0, 1.0)
        worst = max(worst, float(np.percentile(np.degrees(np.arccos(cos)), 95)))
    return worst


def validator_counts(files: list[Path]) -> dict[str, str]:
    """``errors/warnings`` of each file by the Khronos validator, or ``-`` without node."""
    node = shutil.which("node")
    if node is None or not (ROOT / "node_modules" / "gltf-validator").is_dir():
        return {str(f): "-" for f in files}
    proc = subprocess.run(
        [node, str(ROOT / "tools" / "gltf_validate.mjs"), *map(str, files)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    reports = [json.loads(x) for x in proc.stdout.splitlines() if x.startswith("{")]
    return {r["file"]: f"{r['errors']}/{r['warnings']}" for r in reports}


def run_case(name: str, d: Path) -> None:
    paths, L = (ict_inputs if name == "ict" else big_inputs)(d)
    rows = {}
    for label, flags in VARIANTS.items():
        out = d / label.replace(" ", "_").replace("+", "n")
        cmd = [sys.executable, "-m", "conformorph.cli", "morph", *map(str, paths)]
        cmd += ["--landmarks", str(L), "--frames", "30", "--no-metrics", "-q", "-o", str(out)]
        t = time.perf_counter()
        proc = subprocess.run([*cmd, *flags], capture_output=True, text=True, cwd=ROOT)
        wall = time.perf_counter() - t
        if proc.returncode != 0:
            print(f"{name} {label}: exit {proc.returncode}: {proc.stderr.strip()[-300:]}")
            continue
        rows[label] = (out, wall)
    ref_dir = rows["+ normals"][0]
    ref = MorphGlb.load(ref_dir / "animation.glb")
    ft = np.asarray(json.loads((ref_dir / "metrics.json").read_text())["frame_times"])
    ft = ft - ft[0]
    dense = np.linspace(ft[0], ft[-1], 61)
    base = (rows["positions only"][0] / "animation.glb").stat().st_size
    n = ref.base_V.shape[0]
    print(f"\n{name}: {n} vertices written, {len(ft)} frames")
    valid = validator_counts([out / "animation.glb" for out, _ in rows.values()])
    print(
        f"{'variant':16s} {'bytes':>12s} {'x smaller':>9s} {'max err/diag':>12s} {'p95 deg':>8s} "
        f"{'wall s':>7s} {'valid e/w':>9s}"
    )
    for label, (out, wall) in rows.items():
        m = MorphGlb.load(out / "animation.glb")
        err = float("nan") if m.base_V.shape != ref.base_V.shape else 0.0
        for t in dense if err == 0.0 else []:
            R = ref.positions(float(t))
            diag = float(np.linalg.norm(np.ptp(R, axis=0)))
            err = max(err, float(np.linalg.norm(m.positions(float(t)) - R, axis=1).max()) / diag)
        size = (out / "animation.glb").stat().st_size
        print(
            f"{label:16s} {size:12,d} {base / size:9.2f} {err:12.2e} "
            f"{lighting_p95(m, ft, None if np.isnan(err) else ref):8.2f} {wall:7.1f} {valid.get(str(out / 'animation.glb'), '?'):>9s}"
            f"  ({m.base_V.shape[0]} vertices)"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=("ict", "big"), help="one case only (default both)")
    args = ap.parse_args()
    if not FACES.exists():
        sys.exit(f"shared data not found at {FACES}")
    for case in [args.case] if args.case else ["ict", "big"]:
        with tempfile.TemporaryDirectory() as tmp:
            run_case(case, Path(tmp))


if __name__ == "__main__":
    main()
