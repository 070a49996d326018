"""Issue 29's targets checked in the real consumers: Blender (``bpy``), three.js, Babylon.js.

Run::

    .venv/bin/python benchmarks/bench_glb_consumers.py [--output-dir DIR] [--bpy-venv DIR]
        [--bpy-version 5.0.1] [--npm-dir DIR] [--landmarks auto|file] [--reuse]
        [--only three,babylon,blender] [--json OUT.json]

Outputs, made with the default commands (``python -m conformorph.cli``, this checkout):

* ``ict``: ``morph ict_generic_neutral.obj ict_generic_smile.obj ict_generic_jawOpen.obj
  --landmarks L --frames 30 --per-frame`` (L: the shared 68 landmarks, or ``auto``);
* ``textured``: the same three ICT keys written with one planar UV layout (from the
  neutral face) and three smooth test textures (the shared data has no texture images;
  the tests make textured morphs the same way), ``--texture`` one per key;
* ``2d``: ``morph2d flubber_horse.svg flubber_star.svg --per-frame``.

Consumers, each in a folder of its own (never the project's .venv or node_modules):

* Blender: the ``bpy`` wheel (CPython 3.11) in ``--bpy-venv`` (default
  ``$TMPDIR/conformorph-bench-bpy``), created with ``python3.11 -m venv`` and
  ``pip install bpy==VERSION`` when absent; ``glb_consumers/blender_playback.py``
  imports each file with ``bpy.ops.import_scene.gltf`` defaults and evaluates the
  mesh through the depsgraph at every frame time (t × scene fps, with sub-frames);
* Babylon.js 9: ``glb_consumers/package.json`` npm-installed into ``--npm-dir``
  (default ``$TMPDIR/conformorph-bench-glb-consumers``); ``glb_consumers/
  babylon_playback.cjs`` loads with the glTF loader in a ``NullEngine`` and computes
  the morph on the CPU as Babylon's shader does (normals and colours only where the
  morph-target manager says it morphs them);
* three.js r187: ``tools/gltf_three_playback.mjs`` with the repository's node_modules
  (GLTFLoader with three's MeshoptDecoder, an AnimationMixer).

Files compressed with ``EXT_meshopt_compression`` or quantized (``KHR_mesh_quantization``)
are read by each consumer's own loader (Babylon's meshopt decoder is meshoptimizer's,
from npm rather than its CDN) and by the Python reference decoder. Blender 5.0's importer
has no meshopt decoder: when it refuses a file the ``--compress none`` variant (the
README's advice for Blender) is made and checked as ``blender (--compress none)``.

Per consumer: the imported face's height (m, glTF Y at key 0), the rest transform of the
file's top node (node 0, which carries the animation; a quantized file may hold the mesh
on a static child that dequantizes it; Blender keeps no rest apart from the action: the
top object's transform at t = 0), whether scale
is animated, the largest deviation at the key times and at any frame from
``frames/NNN.glb`` relative to the diagonal, the 95th-percentile angle between the
normals it lights with and the frame's true normals (worst frame), the colour at each key
time against the key's texture (mean over the face, sRGB), the 2D GLB's size (m) and
centre. Prints a table; exits 1 when a target fails (see ``TARGETS``), 2 when an output
cannot be made.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from PIL import Image  # noqa: E402

from benchmarks import glb_consumer_measures as gm  # noqa: E402
from benchmarks.glb_consumer_report import print_report, targets_failed  # noqa: E402
from conformorph.pipelines.mesh_io import read_mesh  # noqa: E402

HERE = Path(__file__).resolve().parent / "glb_consumers"
SHARED = Path(os.environ.get("CONFORMORPH_SHARED_DATA") or ROOT.parent / "shared" / "data")
FACES, SHAPES = SHARED / "faces", SHARED / "shapes"
ICT_KEYS = ("neutral", "smile", "jawOpen")
TMP = Path(tempfile.gettempdir())


def cli(args: list[str], log: Path) -> None:
    """``python -m conformorph.cli ARGS`` of this checkout; stderr/stdout kept in ``log``."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "conformorph.cli", *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT)
    log.write_text(" ".join(cmd) + "\n" + proc.stdout + proc.stderr)
    if proc.returncode != 0:
        sys.exit(f"output not made (exit {proc.returncode}): {' '.join(cmd)}\n{proc.stderr}")


def ict_landmarks(out: Path, how: str) -> str:
    if how == "auto":
        return "auto"
    lm = json.loads((FACES / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    path = out / "ict_landmarks.json"
    path.write_text(json.dumps({"landmarks": [lm] * len(ICT_KEYS)}))
    return str(path)


def key_texture(k: int, size: int = 256) -> np.ndarray:
    """Key k's test picture (sRGB in [0, 1], OBJ convention: row 0 is v = 1): smooth,
    different in every channel from key to key."""
    r, c = np.mgrid[0:size, 0:size]
    u, v = (c + 0.5) / size, 1.0 - (r + 0.5) / size
    red = 0.15 + 0.7 * (u if k != 1 else 1.0 - u)
    green = 0.15 + 0.7 * v if k != 2 else 0.5 + 0.3 * np.sin(2 * np.pi * u)
    blue = np.full_like(u, 0.1 + 0.35 * k)
    return np.stack([red, green, blue], axis=2)


def textured_keys(d: Path) -> tuple[list[Path], list[Path]]:
    """The ICT keys with the neutral face's planar UVs, and one texture PNG per key."""
    V0, _ = read_mesh(FACES / "ict_generic_neutral.obj")
    lo, hi = V0[:, :2].min(axis=0), V0[:, :2].max(axis=0)
    uv = 0.05 + 0.9 * (V0[:, :2] - lo) / (hi - lo).max()
    paths, images = [], []
    for k, name in enumerate(ICT_KEYS):
        V, F = read_mesh(FACES / f"ict_generic_{name}.obj")
        lines = [f"v {a:.9g} {b:.9g} {c:.9g}" for a, b, c in V]
        lines += [f"vt {a:.9g} {b:.9g}" for a, b in uv]
        lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in F + 1]
        paths.append(d / f"ict_generic_{name}.obj")
        paths[-1].write_text("\n".join(lines) + "\n")
        images.append(d / f"ict_generic_{name}.png")
        Image.fromarray(np.rint(key_texture(k) * 255).astype(np.uint8)).save(images[-1])
    return paths, images


def make_outputs(out: Path, landmarks: str, reuse: bool, extra: list[str]) -> dict[str, Path]:
    """The three cases' output folders (made unless ``reuse`` finds them)."""
    out.mkdir(parents=True, exist_ok=True)
    L = ict_landmarks(out, landmarks)
    ict = [str(FACES / f"ict_generic_{n}.obj") for n in ICT_KEYS]
    common = ["--landmarks", L, "--frames", "30", "--per-frame", "-q", *extra]
    dirs = {"ict": out / "ict", "textured": out / "textured", "2d": out / "2d"}
    if not (reuse and (dirs["ict"] / "animation.glb").exists()):
        cli(["morph", *ict, *common, "-o", str(dirs["ict"])], out / "ict.log")
    if not (reuse and (dirs["textured"] / "animation.glb").exists()):
        inputs = out / "textured_inputs"
        inputs.mkdir(exist_ok=True)
        paths, images = textured_keys(inputs)
        args = ["morph", *map(str, paths), *common, "--texture", *map(str, images)]
        cli([*args, "-o", str(dirs["textured"])], out / "textured.log")
    if not (reuse and (dirs["2d"] / "animation.glb").exists()):
        shapes = [str(SHAPES / "flubber_horse.svg"), str(SHAPES / "flubber_star.svg")]
        cli(["morph2d", *shapes, "--per-frame", "-q", "-o", str(dirs["2d"])], out / "2d.log")
    return dirs


def ensure_bpy(venv: Path, version: str, python: str | None) -> str | None:
    """The bpy venv's python, installing it when absent; None with the reason printed."""
    exe = venv / "bin" / "python"
    check = [str(exe), "-c", "import bpy; print(bpy.app.version_string)"]
    if exe.exists() and subprocess.run(check, capture_output=True).returncode == 0:
        return str(exe)
    base = python or shutil.which("python3.11")
    if base is None:
        print("Blender not run: the bpy wheels need CPython 3.11 (no python3.11 found)")
        return None
    subprocess.run([base, "-m", "venv", str(venv)], check=True)
    pip = subprocess.run(
        [str(exe), "-m", "pip", "install", f"bpy=={version}"], capture_output=True, text=True
    )
    if pip.returncode != 0:
        print(f"Blender not run: pip install bpy=={version} failed:\n{pip.stderr[-2000:]}")
        return None
    return str(exe)


def ensure_npm(npm_dir: Path) -> bool:
    """npm install of glb_consumers/package.json into ``npm_dir`` (once per version set)."""
    npm = shutil.which("npm")
    if npm is None or shutil.which("node") is None:
        print("Babylon not run: node / npm not found")
        return False
    wanted = (HERE / "package.json").read_text()
    have = npm_dir / "package.json"
    if have.exists() and have.read_text() == wanted and (npm_dir / "node_modules").is_dir():
        return True
    npm_dir.mkdir(parents=True, exist_ok=True)
    have.write_text(wanted)
    subprocess.run([npm, "install", "--no-audit", "--no-fund"], cwd=npm_dir, check=True)
    return True


def run_three(path: Path, times: np.ndarray, work: Path) -> gm.Playback:
    run = gm.Playback("three.js")
    if not (ROOT / "node_modules" / "three").is_dir():
        run.error = "npm three not installed in the repository (npm ci)"
        return run
    out = work / f"three_{path.parent.name}.json"
    cmd = ["node", str(ROOT / "tools" / "gltf_three_playback.mjs"), str(path), str(out)]
    proc = subprocess.run([*cmd, *map(repr, times.tolist())], capture_output=True, text=True)
    if proc.returncode != 0:
        run.error = (proc.stderr.strip().splitlines() or ["failed"])[-1]
        return run
    got = json.loads(out.read_text())
    run.consumer = f"three.js r{got['version']}"
    run.rest = got["rest"]
    run.animated = got["tracks"]
    if got["mesh_rest"] != got["rest"]:
        run.notes.append(f"mesh object's own transform {got['mesh_rest']}")
    frames, n = got["frames"], got["vertex_count"]
    run.positions = np.asarray([f["positions"] for f in frames]).reshape(len(frames), n, 3)
    if frames[0]["normals"] is not None:
        run.normals = np.asarray([f["normals"] for f in frames]).reshape(len(frames), n, 3)
    if frames[0]["colors"] is not None:
        run.colors = np.asarray([f["colors"] for f in frames]).reshape(len(frames), n, -1)
    return run


def run_babylon(npm_dir: Path, path: Path, times: np.ndarray, work: Path) -> gm.Playback:
    run = gm.Playback("Babylon.js")
    out = work / f"babylon_{path.parent.name}.json"
    cmd = ["node", str(HERE / "babylon_playback.cjs"), str(npm_dir), str(path), str(out)]
    proc = subprocess.run([*cmd, *map(repr, times.tolist())], capture_output=True, text=True)
    if proc.returncode != 0:
        run.error = proc.stderr.strip().splitlines()[-1]
        return run
    got = json.loads(out.read_text())
    run.consumer = f"Babylon.js {got['versions']['babylonjs']}"
    node = got["rest"]["top"]
    run.rest = {"position": node["position"], "quaternion": node["quaternion"]}
    run.rest["scale"] = node["scaling"]
    if got["rest"]["node"] != node:
        run.notes.append(f"mesh node's own transform {got['rest']['node']}")
    run.animated = got["animated"]
    n = got["vertex_count"]
    frames = got["frames"]
    run.positions = np.asarray([f["positions"] for f in frames]).reshape(len(frames), n, 3)
    if frames[0]["normals"] is not None:
        run.normals = np.asarray([f["normals"] for f in frames]).reshape(len(frames), n, 3)
    if frames[0]["colors"] is not None:
        run.colors = np.asarray([f["colors"] for f in frames]).reshape(len(frames), n, -1)
    run.notes.append(f"morphs normals: {got['supports']['normals']}")
    run.notes.append(f"morphs colours: {got['supports']['colors']}")
    return run


def run_blender(python: str, path: Path, times: np.ndarray, work: Path) -> gm.Playback:
    run = gm.Playback("Blender")
    out = work / f"blender_{path.parent.name}.npz"
    cmd = [python, str(HERE / "blender_playback.py"), str(path), str(out)]
    proc = subprocess.run([*cmd, *map(repr, times.tolist())], capture_output=True, text=True)
    if proc.returncode != 0 or not out.exists():
        run.error = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        return run
    got = np.load(out)
    meta = json.loads(str(got["meta"]))
    run.consumer = f"Blender {meta['blender']}"
    if "error" in meta:
        run.error = f"import refused: {meta['error']}"
        return run
    w, x, y, z = meta["rest"]["rotation_quaternion"]
    run.rest = {"position": meta["rest"]["location"], "quaternion": [x, y, z, w]}
    run.rest["scale"] = meta["rest"]["scale"]
    run.animated = list(meta["animated_object"])
    if meta.get("mesh_local") is not None:
        run.notes.append(f"mesh object under {meta['rest']['name']}: {meta['mesh_local']}")
    run.positions = got["positions"]
    run.normals = got["corner_normals"]
    run.normal_vertex = got["corner_vertex"]
    if "colors" in got.files:
        run.colors = got["colors"]
    run.notes.append(f"{meta['shape_keys']} shape keys, {meta['animated_shape_keys']} animated")
    run.notes.append(f"custom normals: {meta['custom_normals']}")
    run.notes.append(f"shading {meta['shading']}")
    return run


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--output-dir", type=Path, default=None, help="keep the outputs here")
    p.add_argument("--bpy-venv", type=Path, default=TMP / "conformorph-bench-bpy")
    p.add_argument("--bpy-version", default="5.0.1")
    p.add_argument("--bpy-python", default=None, help="a CPython 3.11 to make the bpy venv")
    p.add_argument("--npm-dir", type=Path, default=TMP / "conformorph-bench-glb-consumers")
    p.add_argument("--landmarks", choices=("file", "auto"), default="file")
    p.add_argument("--reuse", action="store_true", help="keep outputs already in --output-dir")
    p.add_argument("--only", default="three,babylon,blender")
    p.add_argument("--morph-arg", action="append", default=[], help="extra morph flag")
    p.add_argument("--json", type=Path, default=None, help="write the rows here")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    out = args.output_dir or Path(tempfile.mkdtemp(prefix="glb_consumers_"))
    dirs = make_outputs(out, args.landmarks, args.reuse, args.morph_arg)
    only = set(args.only.split(","))
    bpy = (
        ensure_bpy(args.bpy_venv, args.bpy_version, args.bpy_python) if "blender" in only else None
    )
    babylon = "babylon" in only and ensure_npm(args.npm_dir)
    key_times = json.loads((dirs["ict"] / "metrics.json").read_text())["key_times"]
    refs = {case: gm.reference(d, key_times if case != "2d" else None) for case, d in dirs.items()}

    def play(case: str, d: Path) -> list[tuple[gm.Playback, gm.Reference]]:
        """Every consumer's run on the case's animation.glb, with the reference it is
        measured against (a Blender fallback file against its own frames)."""
        ref = refs[case]
        path, times = d / "animation.glb", ref.times
        runs = [(run_three(path, times, out), ref)] if "three" in only else []
        if babylon:
            runs.append((run_babylon(args.npm_dir, path, times, out), ref))
        if bpy is not None:
            runs.append((run_blender(bpy, path, times, out), ref))
            if runs[-1][0].error and "EXT_meshopt" in runs[-1][0].error and case != "2d":
                plain = out / f"{case}-compress-none"
                if not (args.reuse and (plain / "animation.glb").exists()):
                    fallback_case(case, out, args, plain)
                plain_ref = gm.reference(plain, key_times if case != "2d" else None)
                run = run_blender(bpy, plain / "animation.glb", plain_ref.times, out)
                run.consumer += " (--compress none)"
                runs.append((run, plain_ref))
        return runs

    rows: dict[str, list[dict[str, Any]]] = {}
    rows["ict"] = [gm.geometry_row(r, ref) for r, ref in play("ict", dirs["ict"])]
    images = [out / "textured_inputs" / f"ict_generic_{n}.png" for n in ICT_KEYS]
    pictures = [np.asarray(Image.open(p), float) / 255 for p in images]
    rows["textured"] = []
    for r, ref in play("textured", dirs["textured"]):
        uv = gm.file_uv(ref.folder / "animation.glb")
        keys = [gm.texture_at(picture, uv) for picture in pictures]
        rows["textured"].append(gm.colour_row(r, ref, keys))
    rows["2d"] = [gm.shape2d_row(r) for r, _ in play("2d", dirs["2d"])]
    files = {
        case: {"bytes": (d / "animation.glb").stat().st_size, "extensions": refs[case].extensions}
        for case, d in dirs.items()
    }
    print(f"outputs in {out}")
    print_report(rows, files)
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": rows, "files": files}, indent=1, default=str))
    failed = targets_failed(rows)
    for f in failed:
        print(f"TARGET FAILED: {f}")
    return 1 if failed else 0


def fallback_case(case: str, out: Path, args: argparse.Namespace, plain: Path) -> None:
    """The case again with ``--compress none`` (for Blender, which has no meshopt decoder)."""
    L = ict_landmarks(out, args.landmarks)
    common = ["--landmarks", L, "--frames", "30", "--per-frame", "-q", *args.morph_arg]
    common += ["--compress", "none"]
    if case == "ict":
        keys = [str(FACES / f"ict_generic_{n}.obj") for n in ICT_KEYS]
        cli(["morph", *keys, *common, "-o", str(plain)], out / f"{plain.name}.log")
    else:
        inputs = out / "textured_inputs"
        paths = [str(inputs / f"ict_generic_{n}.obj") for n in ICT_KEYS]
        images = [str(inputs / f"ict_generic_{n}.png") for n in ICT_KEYS]
        args_ = ["morph", *paths, *common, "--texture", *images, "-o", str(plain)]
        cli(args_, out / f"{plain.name}.log")


if __name__ == "__main__":
    sys.exit(main())
