"""Cost and accuracy of ``refine="nicp"`` variants on the Table 3 curved ICT sequence.

Run:  .venv/bin/python benchmarks/bench_nicp_variants.py ['[{...}, ...]']

Each variant is a JSON object of keyword arguments for
:class:`conformorph.geometry.nonrigid_icp.NonrigidICPOptions` (e.g. ``{"iterations": 1}``), plus
an optional ``"reg"`` object of :class:`conformorph.pipelines.face_morph.RegistrationOptions`
fields (e.g. ``{"reg": {"nicp_correspondences": 2000}}``; ``{"reg": {"refine":
"guided", ...}}`` measures the guided DMT's settings instead). Prints, per
variant, DMT(nicp)/identity at t = 0.3, 0.5, 1.3, 1.5 (default curvature
homotopy, relative L2 to the true blend, as ``bench_face_tables.py``), the
registration seconds and each pair's non-rigid ICP seconds. The keys are those
of ``bench_face_tables.py`` (key 1 subdivided, key 2 reordered). Default
variants: the shipped settings (:data:`conformorph.geometry.nonrigid_icp.STIFFNESS_SCHEDULE`,
one iteration each), the earlier schedule (three iterations on each of six half
decades), one more supple iteration, and the guided DMT's start instead of the
landmark DMT's.
"""

from __future__ import annotations

import functools
import importlib
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
for p in (ROOT, ROOT / "benchmarks"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

import bench_face_tables as tables  # noqa: E402

from conformorph.pipelines.face_morph import (  # noqa: E402
    FrameOptions,
    RegistrationOptions,
    compute_frames,
    prepare_mesh,
    register_meshes,
)

DEFAULT_VARIANTS = [
    {},
    {"iterations": 3, "stiffness": [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6]},
    {"stiffness": [1e-3, 1e-4, 1e-5, 3e-6, 3e-6, 3e-6, 3e-6]},
    {"reg": {"static_refinement": 1, "static_guided": True, "static_tol": 5e-3}},
]


def main() -> None:
    variants = json.loads(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_VARIANTS
    lm = tables._landmarks()
    N, F = tables._load("ict_generic_neutral.obj")
    S, _ = tables._load("ict_generic_smile.obj")
    J, _ = tables._load("ict_generic_jawOpen.obj")
    wa, wb = tables.PATHS["curved"]
    key_t = np.array([0.0, 1.0, 2.0])
    keys = [tables._blend(N, S, J, wa(t), wb(t)) for t in key_t]
    truths = [(t, tables._blend(N, S, J, wa(t), wb(t)), F) for t in (0.3, 0.5, 1.3, 1.5)]
    same = [prepare_mesh(keys[i], F, lm, mesh_index=i) for i in range(3)]
    V1, F1 = tables.subdivide(keys[1], F)
    V2, F2, inv = tables.reorder(keys[2], F)
    diff = [
        same[0],
        prepare_mesh(V1, F1, lm, mesh_index=1),
        prepare_mesh(V2, F2, [int(inv[j]) for j in lm], mesh_index=2),
    ]
    inputs_diff = [(keys[0], F), (V1, F1), (V2, F2)]
    reg_id = register_meshes(same, RegistrationOptions(method="identity", baselines=False))
    no_metrics = FrameOptions(key_metrics=False)
    fr_id = compute_frames(reg_id, [(k, F) for k in keys], key_t, key_t, no_metrics, truths=truths)
    ident = [e["L2"] for e in fr_id["meta"]["truth_errors"]["identity"]]
    module = importlib.import_module("conformorph.geometry.nonrigid_icp")
    shipped = module.nonrigid_icp
    print(
        f"{'variant':<60} {'nicp/id at t = 0.3, 0.5, 1.3, 1.5':<34} {'reg s':>6}  nicp s per pair"
    )
    try:
        for variant in variants:
            kw = dict(variant)
            reg_kw = kw.pop("reg", {})
            module.nonrigid_icp = functools.partial(
                shipped, options=module.NonrigidICPOptions(**kw)
            )
            t0 = time.perf_counter()
            reg_kw = {"refine": "nicp", **reg_kw}
            reg = register_meshes(diff, RegistrationOptions(baselines=False, **reg_kw))
            seconds = time.perf_counter() - t0
            fr = compute_frames(reg, inputs_diff, key_t, key_t, no_metrics, truths=truths)
            d = [e["L2"] for e in fr["meta"]["truth_errors"]["dmt"]]
            pairs = [p["nicp"] or {} for p in reg["meta"]["pairs"]]
            ratios = " ".join(f"{a / b:.3f}" for a, b in zip(d, ident, strict=True))
            print(
                f"{json.dumps(variant):<60} {ratios:<34} {seconds:>6.2f}  "
                f"{[round(p.get('seconds', 0.0), 2) for p in pairs]}",
                flush=True,
            )
    finally:
        module.nonrigid_icp = shipped


if __name__ == "__main__":
    main()
