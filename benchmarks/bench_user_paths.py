"""What users run, timed as they run it: the ``conformorph morph`` command and the HTTP job.

Run::

    .venv/bin/python benchmarks/bench_user_paths.py [--part cli|http|all] [--case ict|big]
        [--repeat 5] [--warm 4]

``cli``: ``conformorph morph M0 M1 --landmarks L.json --frames 30 -o OUT`` with every
other option at its default, each run a fresh process (interpreter start, imports and
file reading included), ``--repeat`` times; min, median and max of the wall time, and
the median of each stage the command reports in ``metrics.json`` (``seconds``).

``cli`` runs three ways: the key cache off (``--no-cache``), cold (an empty ``--cache``
folder each run) and warm (one folder a first, untimed run filled: the same meshes
again); each run's key-cache states (``hit``/``stored``) and the hits are printed.

``http``: a freshly started ``conformorph serve`` on its embedded default (a real
Celery worker on the embedded broker, a temporary data folder), timed from the moment
``/readyz`` answers 200: per job, the two uploads (new bytes each time, as a user's
new meshes), the time from submission until
``animation.glb`` can be fetched, and until the job has succeeded; the first job after
start, then ``--warm`` more; then ``--warm`` jobs on the last job's meshes again (no
upload: each mesh's work is ready), with their key-cache hits; the stage split is the
job's own ``stages[].seconds``.

Cases: ``ict`` is two ICT faces (``ict_generic_neutral`` → ``ict_generic_smile``, 7k
vertices, the shared 68 landmarks); ``big`` is two 68k-vertex faces
(``choi_human_face`` subdivided once, the second deformed smoothly, 30 landmarks by
farthest-point sampling within 0.3 diameters of the centre and, since issue 32, at
least 0.05 diameters from the boundary; ``--big-old-landmarks`` samples as before,
2 landmarks then on the boundary), as ``benchmarks/bench_face_speed.py`` builds them.
Needs ``../shared/data/faces``. Nothing here is part of the test run.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

ROOT = Path(__file__).resolve().parents[1]
#: the shared faces beside the repository; SHARED_FACES names them elsewhere (a worktree)
FACES = Path(os.environ.get("SHARED_FACES") or ROOT.parent / "shared" / "data" / "faces")
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


#: ``--big-old-landmarks``: the big case's landmarks as sampled before issue 32 (2 on the
#: mesh's boundary)
BIG_OLD_LANDMARKS = False


def ict_case(d: Path) -> tuple[list[Path], list[list[int]]]:
    lm = json.loads((FACES / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    return [FACES / "ict_generic_neutral.obj", FACES / "ict_generic_smile.obj"], [lm, lm]


def big_case(d: Path) -> tuple[list[Path], list[list[int]]]:
    import numpy as np

    from benchmarks.bench_face_tables import subdivide
    from conformorph.geometry.static_correspondences import farthest_point_samples
    from conformorph.pipelines.mesh_io import read_mesh, write_obj

    V, F = subdivide(*read_mesh(FACES / "choi_human_face.obj"))
    c = V.mean(axis=0)
    diam = float(np.linalg.norm(V.max(0) - V.min(0)))
    V2 = V + 0.03 * diam * np.sin(3 * (V - c) / diam)[:, [1, 2, 0]]
    write_obj(d / "big_a.obj", V, F)
    write_obj(d / "big_b.obj", V2, F)
    inner = np.linalg.norm(V[:, :2] - c[:2], axis=1) < 0.3 * diam
    if not BIG_OLD_LANDMARKS:
        # and 0.05 diameters from the boundary: the disk of 0.3 diameters reaches the
        # narrow face's edge, and the sampling put 2 of the 30 on it (issue 32: every
        # DMT fit then failed, MT was used; now such landmarks leave the DMT's fit)
        from scipy.spatial import cKDTree

        from conformorph.geometry.boundary_loop import boundary_loops

        rim = np.concatenate(boundary_loops(F))
        inner &= cKDTree(V[rim]).query(V)[0] > 0.05 * diam
    ids = [int(i) for i in farthest_point_samples(V, 30, candidates=np.flatnonzero(inner))]
    return [d / "big_a.obj", d / "big_b.obj"], [ids, ids]


def _env(data_dir: Path | None = None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
    env["PYTHONPATH"] = str(ROOT)
    if data_dir is not None:
        env["CONFORMORPH_DATA_DIR"] = str(data_dir)
    return env


def _spread(xs: list[float]) -> str:
    return f"min {min(xs):.2f}  median {statistics.median(xs):.2f}  max {max(xs):.2f} s"


def _load() -> str:
    """The machine's load averages (1, 5, 15 min) and cores: timings on a shared machine
    are inflated, and this says by how much it was shared."""
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} {five:.2f} {fifteen:.2f} on {os.cpu_count()} cores"


def _stage_medians(rows: list[dict[str, float]]) -> str:
    names = [k for k in rows[0] if all(k in r for r in rows)]
    return "  ".join(f"{k} {statistics.median(r[k] for r in rows):.2f}" for k in names)


def _cache_states(metrics: dict[str, Any]) -> str:
    """Each key's key-cache state in a run's metrics (``hit``, ``stored``, ... or ``off``)."""
    return "/".join(i.get("cache", {}).get("state", "off") for i in metrics["inputs"])


def _cli_runs(
    d: Path, meshes: list[Path], L: Path, repeat: int, extra: list[str], cache: str
) -> tuple[list[float], list[dict[str, float]], list[str], dict[str, Any]]:
    """``repeat`` fresh ``conformorph morph`` processes; ``cache``: ``off`` (--no-cache),
    ``cold`` (a new --cache folder each run) or ``warm`` (one folder, filled by a run
    before the timed ones: the same meshes again)."""
    walls, stages, states = [], [], []
    folder = d / f"cache-{cache}"
    flags = {"off": ["--no-cache"], "warm": ["--cache", str(folder)]}.get(cache, [])
    if cache == "warm":  # the first morph of these meshes, not timed
        cmd = [sys.executable, "-m", "conformorph.cli", "morph", *map(str, meshes)]
        cmd += ["--landmarks", str(L), "--frames", "30", "-o", str(d / "fill"), "-q"]
        subprocess.run(
            cmd + flags + extra, env=_env(), cwd=d, check=True, stdout=subprocess.DEVNULL
        )
    m: dict[str, Any] = {}
    for k in range(repeat):
        out = d / f"out-{cache}{k}"
        if cache == "cold":
            flags = ["--cache", str(d / f"cache-cold{k}")]
        cmd = [sys.executable, "-m", "conformorph.cli", "morph", *map(str, meshes)]
        cmd += ["--landmarks", str(L), "--frames", "30", "-o", str(out), "-q", *flags, *extra]
        t0 = time.perf_counter()
        subprocess.run(cmd, env=_env(), cwd=d, check=True, stdout=subprocess.DEVNULL)
        walls.append(time.perf_counter() - t0)
        m = json.loads((out / "metrics.json").read_text())
        stages.append(m["seconds"])
        states.append(_cache_states(m))
    return walls, stages, states, m


def bench_cli(case: str, repeat: int, extra: list[str] | None = None) -> None:
    """``conformorph morph`` with the key cache off, cold and warm (same meshes again)."""
    with tempfile.TemporaryDirectory(prefix="conformorph-bench-") as tmp:
        d = Path(tmp)
        meshes, lm = (ict_case if case == "ict" else big_case)(d)
        L = d / "landmarks.json"
        L.write_text(json.dumps({"landmarks": lm}))
        flags = " ".join(extra or []) or "defaults"
        for cache in ("off", "cold", "warm"):
            walls, stages, states, m = _cli_runs(d, meshes, L, repeat, extra or [], cache)
            nodes = ", ".join(f"{i['n_vertices']}" for i in m["inputs"])
            fb = len(m["bijectivity"]["fallbacks"])
            print(
                f"\n## conformorph morph, {case}, 30 frames, {flags}, key cache {cache}, "
                f"{repeat} fresh processes"
            )
            print(
                f"key meshes as morphed (after preparation): {nodes} vertices; DMT "
                f"fallbacks {fb}; key-frame L2 dmt "
                f"{m['frames'].get('key_frame_L2_to_inputs', {}).get('dmt')}"
            )
            print(f"after the runs: {_load()}")
            print(f"wall: {_spread(walls)}  (runs: {', '.join(f'{w:.2f}' for w in walls)})")
            print(
                f"key cache per run: {', '.join(states)}  (hits {sum(s.count('hit') for s in states)})"
            )
            print(f"stage medians (s): {_stage_medians(stages)}")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _start_server(data_dir: Path) -> tuple[subprocess.Popen[bytes], str, float]:
    port = _free_port()
    cmd = [
        sys.executable,
        "-m",
        "conformorph.cli",
        "serve",
        "--port",
        str(port),
        "--data-dir",
        str(data_dir),
    ]
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        cmd,
        env=_env(data_dir),
        cwd=data_dir,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    base = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 180
    while True:
        try:
            if httpx.get(f"{base}/readyz", timeout=5).status_code == 200:
                return proc, base, time.perf_counter() - t0
        except httpx.TransportError:
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError("conformorph serve did not become ready")
        time.sleep(0.05)


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(30)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def _one_job(
    c: httpx.Client,
    meshes: list[Path],
    lm: list[list[int]],
    run: int,
    same: list[str] | None = None,
) -> dict[str, Any]:
    # new bytes every run (an OBJ comment): the server recognises a re-upload of the same
    # bytes and skips its validation, which a user with new meshes does not get; with
    # ``same`` (mesh ids) no upload: the same meshes morphed again
    files = [(p.name, p.read_bytes() + f"\n# run {run}\n".encode()) for p in meshes]
    t0 = time.perf_counter()
    ids = list(same or [])
    for name, body in files if same is None else []:
        r = c.post("/v1/meshes", files={"file": (name, body)}, timeout=300)
        r.raise_for_status()
        ids.append(r.json()["id"])
    t_up = time.perf_counter()
    r = c.post("/v1/morphs", json={"meshes": ids, "landmarks": lm, "frames": 30}, timeout=60)
    r.raise_for_status()
    jid = r.json()["id"]
    t_glb = None
    while True:
        job = c.get(f"/v1/jobs/{jid}", timeout=60).json()
        if t_glb is None and any(a["name"] == "animation.glb" for a in job.get("artifacts", [])):
            g = c.get(f"/v1/jobs/{jid}/artifacts/animation.glb", timeout=60)
            if g.status_code == 200 and g.content[:4] == b"glTF":
                t_glb = time.perf_counter()
        if job["state"] not in ("queued", "running"):
            break
        time.sleep(0.02)
    t_end = time.perf_counter()
    if job["state"] != "succeeded":
        raise RuntimeError(f"job {jid} ended {job['state']}: {job.get('error')}")
    metrics = c.get(f"/v1/jobs/{jid}/artifacts/metrics.json", timeout=60).json()
    return {
        "ids": ids,
        "cache": _cache_states(metrics),
        "uploads": t_up - t0,
        "glb_after_submit": (t_glb or t_end) - t_up,
        "success_after_submit": t_end - t_up,
        "upload_to_success": t_end - t0,
        "stages": {s["name"]: s["seconds"] for s in job.get("stages", []) if s.get("seconds")},
    }


def bench_http(case: str, warm: int) -> None:
    with tempfile.TemporaryDirectory(prefix="conformorph-bench-") as tmp:
        d = Path(tmp)
        meshes, lm = (ict_case if case == "ict" else big_case)(d)
        data = d / "data"
        data.mkdir()
        proc, base, ready = _start_server(data)
        try:
            with httpx.Client(base_url=base) as c:
                rows = [_one_job(c, meshes, lm, k) for k in range(1 + warm)]
                # the same meshes again: each one's work stored by the job before
                again = [_one_job(c, meshes, lm, 0, rows[-1]["ids"]) for _ in range(max(1, warm))]
        finally:
            _stop(proc)
    print(f"\n## POST /v1/morphs on a fresh `conformorph serve` (embedded default), {case}")
    print(f"after the jobs: {_load()}")
    print(f"serve started to /readyz 200: {ready:.2f} s")
    for k, r in enumerate(rows):
        label = "first" if k == 0 else f"warm {k}"
        print(
            f"{label:7s} uploads {r['uploads']:.2f}  GLB fetchable {r['glb_after_submit']:.2f} "
            f"after submit  success {r['success_after_submit']:.2f} after submit  "
            f"upload->success {r['upload_to_success']:.2f} s  stages "
            + "  ".join(f"{n} {s:.2f}" for n, s in r["stages"].items())
            + f"  key cache {r['cache']}"
        )
    for r in again:
        print(
            f"same    GLB fetchable {r['glb_after_submit']:.2f} after submit  success "
            f"{r['success_after_submit']:.2f} after submit  stages "
            + "  ".join(f"{n} {s:.2f}" for n, s in r["stages"].items())
            + f"  key cache {r['cache']}"
        )
    print(
        f"same meshes again, submit->success: "
        f"{_spread([r['success_after_submit'] for r in again])}; GLB after submit: "
        f"{_spread([r['glb_after_submit'] for r in again])}; key-cache hits "
        f"{sum(r['cache'].count('hit') for r in again)} of {2 * len(again)}"
    )
    if warm:
        w = rows[1:]
        print(f"warm upload->success: {_spread([r['upload_to_success'] for r in w])}")
        print(f"warm GLB after submit: {_spread([r['glb_after_submit'] for r in w])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("cli", "http", "all"), default="all")
    ap.add_argument("--case", choices=("ict", "big"), default="ict")
    ap.add_argument("--repeat", type=int, default=5, help="fresh `conformorph morph` processes")
    ap.add_argument("--warm", type=int, default=4, help="jobs after the first on one server")
    ap.add_argument(
        "--morph-args",
        default="",
        help="extra `conformorph morph` flags for --part cli, e.g. '--vertex-budget 0' "
        "(the heading then says so: not the default path)",
    )
    ap.add_argument(
        "--big-old-landmarks",
        action="store_true",
        help="the big case's landmarks as sampled before issue 32 (2 of them on the boundary)",
    )
    args = ap.parse_args()
    global BIG_OLD_LANDMARKS
    BIG_OLD_LANDMARKS = args.big_old_landmarks
    if not FACES.is_dir():
        sys.exit(f"shared data not found at {FACES}")
    if args.part in ("cli", "all"):
        bench_cli(args.case, max(1, args.repeat), args.morph_args.split())
    if args.part in ("http", "all"):
        bench_http(args.case, max(0, args.warm))


if __name__ == "__main__":
    main()
