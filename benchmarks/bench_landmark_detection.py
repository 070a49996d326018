"""Automatic landmarks (issue 16): detection rate, rotation stability, accuracy and speed.

Run (mediapipe==0.10.14 and embreex installed, see the README)::

    PYTHONPATH=. python benchmarks/bench_landmark_detection.py [--data DIR] [--rotations N]
        [--rotation-faces a,b,...] [--json OUT]

1. Every shared face (``ict_*``, ``meshmonk_*``, ``choi_*``, ``gpp_face``): detected or the named
   failure, detector score, warnings, seconds per face (model load excluded, reported apart).
2. Rotated copies of ``--rotation-faces``: ±30° and ±60° about each axis plus ``--rotations``
   random rotations (and a translation); each must be detected, and its landmarks, carried back
   to the unrotated mesh by their triangles and barycentrics, must be within 0.1 mm (0.01 ICT cm
   units; other meshes in their own units, scaled to the same fraction of the eye distance) of
   the unrotated answer.
3. ICT accuracy of the committed table against ``ict_landmarks68.json`` (the table was fitted on
   these meshes; the held-out, leave-one-identity-out figures it stores are printed beside).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from conformorph.pipelines.landmark_detection.detect import (  # noqa: E402
    DetectedLandmarks,
    detect_landmarks,
    shared_models,
)
from conformorph.pipelines.landmark_detection.detection_errors import LandmarkDetectionError  # noqa: E402
from conformorph.pipelines.landmark_detection.multipie68 import INNER_51, load_multipie68_table  # noqa: E402
from conformorph.pipelines.mesh_io import read_mesh  # noqa: E402

DEFAULT_ROTATION_FACES = "ict_generic_neutral,meshmonk_SIMPOP_01,choi_human_face,gpp_face"


def rotation(axis: int, degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    i, j = [k for k in range(3) if k != axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def on_mesh(r: DetectedLandmarks, V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The landmarks as points of (V, F), by their triangles and barycentrics."""
    return np.einsum("mj,mjk->mk", r.barycentric, V[F[r.triangle]])


def eye_distance(P: np.ndarray) -> float:
    return float(np.linalg.norm(P[45] - P[36]))


def shared_faces(data: Path) -> dict:
    rows = {}
    for path in sorted(data.glob("*.obj")):
        V, F = read_mesh(path)
        try:
            r = detect_landmarks(V, F)
        except LandmarkDetectionError as exc:
            rows[path.stem] = {"detected": False, "error": exc.code, "message": str(exc)}
            print(f"{path.stem:28s} FAILED {exc.code}: {exc}")
            continue
        rows[path.stem] = {"detected": True, "score": r.score, "seconds": r.seconds,
                           "warnings": list(r.warnings), "min_confidence": float(r.confidence.min())}
        print(f"{path.stem:28s} score {r.score:.3f}  {r.seconds:.2f} s  "
              f"warnings {len(r.warnings)}  min conf {r.confidence.min():.2f}")
    return rows


def rotated_copies(data: Path, faces: list[str], n_random: int) -> dict:
    rng = np.random.default_rng(16)
    out = {}
    for name in faces:
        V, F = read_mesh(data / f"{name}.obj")
        base = on_mesh(detect_landmarks(V, F), V, F)
        # 0.1 mm on ICT (cm units) is 0.01 / 9 of an outer-eye-corner distance of ~9 cm
        tol = 0.01 / 9.0 * eye_distance(base)
        rots = [(f"axis{ax} {deg:+d}", rotation(ax, deg)) for ax in range(3)
                for deg in (-60, -30, 30, 60)]
        rots += [(f"random {i}", random_rotation(rng)) for i in range(n_random)]
        rows = []
        for label, R in rots:
            Vr = V @ R.T + rng.normal(size=3) * 5.0
            try:
                dev = float(np.linalg.norm(on_mesh(detect_landmarks(Vr, F), V, F) - base,
                                           axis=1).max())
                rows.append({"rotation": label, "detected": True, "max_dev": dev,
                             "within": dev <= tol})
            except LandmarkDetectionError as exc:
                rows.append({"rotation": label, "detected": False, "error": exc.code})
        ok = sum(r["detected"] for r in rows)
        within = sum(r.get("within", False) for r in rows)
        worst = max((r["max_dev"] / tol * 0.1 for r in rows if r["detected"]), default=float("nan"))
        print(f"{name:28s} rotated: detected {ok}/{len(rows)}, within 0.1 mm-equivalent "
              f"{within}/{len(rows)}, worst {worst:.3f} mm-equivalent")
        out[name] = {"tolerance": tol, "rows": rows}
    return out


def ict_accuracy(data: Path) -> dict:
    ids = json.loads((data / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    errs = {}
    for path in sorted(data.glob("ict_*.obj")):
        V, F = read_mesh(path)
        errs[path.stem] = 10.0 * np.linalg.norm(detect_landmarks(V, F).points - V[ids], axis=1)
    E = np.stack(list(errs.values()))
    res = {"mean_mm_68": float(E.mean()), "mean_mm_inner51": float(E[:, list(INNER_51)].mean()),
           "per_mesh_mean_mm": {k: float(v.mean()) for k, v in errs.items()}}
    meta = load_multipie68_table().meta
    print(f"ICT (calibration faces): mean {res['mean_mm_68']:.2f} mm over 68, "
          f"{res['mean_mm_inner51']:.2f} mm over the inner 51; held out (table's record): "
          f"{meta.get('held_out_error')}")
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "faces")
    ap.add_argument("--rotations", type=int, default=4, help="random rotations per face")
    ap.add_argument("--rotation-faces", default=DEFAULT_ROTATION_FACES)
    ap.add_argument("--json", type=Path, help="write the results here")
    args = ap.parse_args()
    t0 = time.perf_counter()
    models = shared_models()
    print(f"model load {models.load_seconds:.2f} s (mediapipe {models.version})")
    shared = shared_faces(args.data)
    secs = [r["seconds"] for r in shared.values() if r["detected"]]
    print(f"shared faces: detected {len(secs)}/{len(shared)}; seconds per face median "
          f"{np.median(secs):.2f}, max {np.max(secs):.2f}")
    rotated = rotated_copies(args.data, args.rotation_faces.split(","), args.rotations)
    accuracy = ict_accuracy(args.data)
    result = {"model_load_seconds": models.load_seconds, "shared": shared, "rotated": rotated,
              "ict": accuracy, "wall_seconds": time.perf_counter() - t0}
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
