"""Fit the MediaPipe 478 → Multi-PIE 68 table on the annotated ICT-FaceKit meshes.

Writes ``pipelines/landmark_detection/multipie68_table.json`` (the committed
table) and prints the held-out errors that choose its options.

Method: every ``ict_*.obj`` in the data folder goes through the detector's view
choice and FaceMesh (:func:`conformorph.pipelines.landmark_detection.detect.facemesh_in_view`);
the annotated Multi-PIE vertices (``ict_landmarks68.json``, 0-based, valid for
every ICT mesh) are projected into the same image. For each option pair (points
per landmark, ridge) of a small grid, the table is fitted leaving one ICT
identity out (generic with its 7 expressions, sample with 3, rand1, rand2) and
the held-out meshes' landmarks are cast onto their surfaces; the 3D errors
(ICT units are cm; reported in mm) choose the options, and the committed table
is then fitted on all meshes with them.

Run (mediapipe and embreex installed, see README)::

    PYTHONPATH=. python scripts/calibrate_landmarks.py [--data ../shared/data/faces]
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
    DetectionOptions,
    FaceMeshView,
    choose_view,
    facemesh_in_view,
    shared_models,
    surface_landmarks_from_pixels,
)
from conformorph.pipelines.landmark_detection.multipie68 import (  # noqa: E402
    INNER_51,
    TABLE_PATH,
    multipie68_from_facemesh,
)
from conformorph.pipelines.landmark_detection.multipie68_fit import (  # noqa: E402
    TableFitOptions,
    fit_multipie68_table,
)
from conformorph.pipelines.landmark_detection.render import MeshRayCaster  # noqa: E402
from conformorph.pipelines.mesh_io import read_mesh  # noqa: E402

GRID_POINTS = (1, 10, 24, 32)
GRID_RIDGE = (1e-4, 1e-3, 3e-3)
MM_PER_UNIT = 10.0  # ICT units are cm


def say(text: str) -> None:
    """Progress and results on stderr."""
    sys.stderr.write(text + "\n")


def identity_of(name: str) -> str:
    """``ict_generic_smile`` → ``generic``."""
    return name.split("_")[1]


def observe(data: Path) -> list[dict]:
    """Per ICT mesh: caster, view, FaceMesh points and the projected annotated landmarks."""
    gt = np.asarray(json.loads((data / "ict_landmarks68.json").read_text())
                    ["landmarks_multipie68_0based"])
    models = shared_models()
    opts = DetectionOptions()
    out = []
    for path in sorted(data.glob("ict_*.obj")):
        V, F = read_mesh(path)
        caster = MeshRayCaster(V, F)
        cam, score = choose_view(caster, models, opts)
        view = facemesh_in_view(caster, models, cam, score, opts)
        out.append({
            "name": path.stem, "caster": caster, "view": view, "truth": V[gt],
            "target": view.render.camera.project(V[gt]),
        })
        say(f"  {path.stem}: score {score:.3f}")
    return out


def errors_mm(obs: dict, table) -> np.ndarray:
    """3D error (68,) in mm of the table's landmarks on one observed mesh."""
    view: FaceMeshView = obs["view"]
    pix = multipie68_from_facemesh(view.points, table)
    tri, bary, _, _ = surface_landmarks_from_pixels(obs["caster"], view, pix, DetectionOptions())
    V, F = obs["caster"].V, obs["caster"].F
    pts = np.einsum("mj,mjk->mk", bary, V[F[tri]])
    return MM_PER_UNIT * np.linalg.norm(pts - obs["truth"], axis=1)


def held_out(observed: list[dict], options: TableFitOptions) -> dict[str, np.ndarray]:
    """Leave-one-identity-out errors (68,) in mm per mesh."""
    out = {}
    for ident in sorted({identity_of(o["name"]) for o in observed}):
        train = [o for o in observed if identity_of(o["name"]) != ident]
        table = fit_multipie68_table([o["view"].points for o in train],
                                     [o["target"] for o in train], options)
        for o in observed:
            if identity_of(o["name"]) == ident:
                out[o["name"]] = errors_mm(o, table)
    return out


def summary(errs: dict[str, np.ndarray]) -> dict[str, float]:
    E = np.stack(list(errs.values()))
    inner = np.asarray(INNER_51)
    return {"mean_mm_68": float(E.mean()), "mean_mm_inner51": float(E[:, inner].mean()),
            "max_mm": float(E.max()), "jaw_mean_mm": float(E[:, :17].mean())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "faces")
    ap.add_argument("-o", "--output", type=Path, default=TABLE_PATH)
    args = ap.parse_args()
    t0 = time.perf_counter()
    observed = observe(args.data)
    say(f"observed {len(observed)} meshes in {time.perf_counter() - t0:.1f} s")
    results = []
    for k in GRID_POINTS:
        for ridge in GRID_RIDGE if k > 1 else (0.0,):
            s = summary(held_out(observed, TableFitOptions(k, ridge)))
            results.append((s["mean_mm_68"], k, ridge, s))
            say(f"k={k:2d} ridge={ridge:<6g} " + "  ".join(f"{a} {b:.3f}" for a, b in s.items()))
    _, k, ridge, best = min(results, key=lambda r: r[0])
    errs = held_out(observed, TableFitOptions(k, ridge))
    meta = {
        "note": "MediaPipe FaceMesh (478, refine_landmarks) -> Multi-PIE 68 (0-based order); each "
        "landmark = sum(weight * facemesh[index]) in image space; fitted by "
        "scripts/calibrate_landmarks.py",
        "mediapipe_version": shared_models().version,
        "calibration_meshes": [o["name"] for o in observed],
        "points_per_landmark": k,
        "ridge": ridge,
        "held_out": "leave one ICT identity out (generic x7, sample x3, rand1, rand2)",
        "held_out_error": {key: round(v, 3) for key, v in best.items()},
        "held_out_mean_mm_per_mesh": {n: round(float(e.mean()), 3) for n, e in errs.items()},
    }
    table = fit_multipie68_table([o["view"].points for o in observed],
                                 [o["target"] for o in observed], TableFitOptions(k, ridge), meta)
    args.output.write_text(json.dumps(table.to_json(), separators=(",", ":")) + "\n")
    say(f"chose k={k} ridge={ridge}: {best}; wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
