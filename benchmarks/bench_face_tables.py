"""Tables 2 and 3 of the face morphing paper, reproduced on the ICT faces.

Run:  .venv/bin/python benchmarks/bench_face_tables.py [--quick] [--table2-only | --table3-only]

Table 2 (registration): ICT pairs generic neutral→smile, neutral→jawOpen,
generic neutral→sample neutral (68 landmarks). E_D (eq. 2) and E (eq. 3) for
MT and the paper's DMT (landmarks only), folded triangles, min Jacobian.
Because the thin-plate part interpolates the landmarks exactly (centres at
the landmarks), E_D and E of DMT at the fitted landmarks are ~0 by
construction; the meaningful figures are the held-out ones: k-fold
cross-validation (:mod:`conformorph.geometry.landmark_cross_validation`, 10 folds: fit on
~90 % of the landmarks, map the rest, E_D and E over every landmark's held-out
image). Since the ICT meshes share connectivity, the dense error against the
known correspondence (every vertex of mesh 0 mapped by f̄ and compared with
the same vertex of mesh 1, in 3D) is printed as an evaluation too.

Table 3 (morphing): key frames at t = 0, 1, 2 built from ICT blend shapes,
frames compared with the true blend at t = 0.3, 0.5, 1.3, 1.5 by the
area-weighted distance to the true surface relative to its bounding-box
diagonal (L2). Methods: identity (oracle correspondence, same connectivity),
DMT and MT with key frames of different connectivity (key 1 subdivided once,
key 2 with its vertices reordered), and linear vertex interpolation. Two
paths: "curved" (smile weight t(2−t), jawOpen weight t²/4: not linear in
vertex space) and "linear" (smile weight t/2: linear interpolation is exact
there by construction). The curvature homotopies (vector Hn and the paper's
scalar H, each on the disk Laplacian; the vector Hn on the Laplacian of
the interpolated metric, "metric"; and that one screened towards the cubic
spline of the key positions, "screened") are measured. Note that both paths
are polynomial (degree ≤ 2) in vertex space, which favours any homotopy that
follows a spline of positions (linear interpolation is exact on the linear
path, the cubic spline nearly so on both). "DMT" is the default
registration (``refine="auto"``, on these 7k-node meshes ``"nicp"``: landmarks
plus dense correspondences from a non-rigid ICP, an extension); "DMT(guided)"
is ``refine="guided"`` (landmarks plus deformation-guided closest-point
correspondences, the default above 20,000 nodes); "DMT(paper)" uses the landmarks only;
"ceiling" is DMT given 1000 exact correspondences per pair besides the
landmarks (known here because the keys come from one rig): an evaluation of
how much of DMT's excess over identity is the registration's lack of
information, not a method.

``--landmark-variants`` (issue 16): the Table 3 path (curved, screened homotopy,
default DMT) with the landmarks given exactly (68), perturbed by 3 mm rms per axis
on every key independently (seeded, snapped to vertices; mm from the ICT outer eye
corners, 89.2 mm apart), 5 only (inner eye corners, nose tip, mouth corners) and
auto-detected (``conformorph.pipelines.landmark_detection`` on each key, its confidences
passed on), each with ``landmark_fit`` exact and tolerant; the error at every t,
its ratio to the exact-landmark morph of the same fit and to today's (exact/exact).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from conformorph.pipelines.face_morph import (  # noqa: E402
    FrameOptions,
    RegistrationOptions,
    compute_frames,
    prepare_mesh,
    register_meshes,
)
from conformorph.pipelines.mesh_io import read_mesh  # noqa: E402

#: the shared faces beside the repository; SHARED_FACES names them elsewhere (a worktree)
FACES = Path(os.environ.get("SHARED_FACES") or ROOT.parent / "shared" / "data" / "faces")


def _load(name: str) -> tuple[np.ndarray, np.ndarray]:
    return read_mesh(FACES / name)


def _landmarks() -> list[int]:
    return json.loads((FACES / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]


def subdivide(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """1→4 midpoint subdivision; original vertex ids kept (the surface is unchanged)."""
    from conformorph.geometry.mesh_edges import mesh_edges

    E = mesh_edges(F)
    n = V.shape[0]
    V2 = np.vstack([V, 0.5 * (V[E.edges[:, 0]] + V[E.edges[:, 1]])])
    e = n + E.halfedge_edge
    a, b, c = F.T
    ab, bc, ca = e.T
    F2 = np.vstack([np.c_[a, ab, ca], np.c_[ab, b, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]])
    return V2, F2.astype(np.int64)


def reorder(
    V: np.ndarray, F: np.ndarray, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random vertex permutation; returns (V', F', old→new index map)."""
    perm = np.random.default_rng(seed).permutation(V.shape[0])
    inv = np.argsort(perm)
    return V[perm], inv[F], inv


# --------------------------------------------------------------------------- Table 2


def table2(folds: int = 10) -> list[dict]:
    from conformorph.geometry.disk_registration import register_disk_landmarks
    from conformorph.geometry.landmark_cross_validation import cross_validate_registration
    from conformorph.geometry.point_location import PointLocator
    from conformorph.geometry.registration_error import surface_registration_error

    lm = _landmarks()
    pairs = [
        ("neutral→smile", "ict_generic_neutral.obj", "ict_generic_smile.obj"),
        ("neutral→jawOpen", "ict_generic_neutral.obj", "ict_generic_jawOpen.obj"),
        ("generic→sample", "ict_generic_neutral.obj", "ict_sample_neutral.obj"),
    ]
    rows = []
    for name, a, b in pairs:
        Va, F = _load(a)
        Vb, _ = _load(b)
        pa = prepare_mesh(Va, F, lm)
        pb = prepare_mesh(Vb, F, lm, mesh_index=1)
        reg = register_meshes([pa, pb], RegistrationOptions(method="dmt", consistent="source"))
        pm = reg["meta"]["pairs"][0]  # the pipeline's default DMT (landmarks + guided points)
        P, Q = pa["lm_uv"], pb["lm_uv"]
        loc_a, loc_b = PointLocator(pa["uv"], F), PointLocator(pb["uv"], F)
        # λ1²/λ0² at the landmarks, as the pipeline passes it (ratio of area factors)
        scale = loc_b.locate(Q).interpolate(F, pb["lam"]) / loc_a.locate(P).interpolate(
            F, pa["lam"]
        )

        def E(mapped: np.ndarray, pb: dict = pb, F: np.ndarray = F, loc: object = loc_b) -> float:
            """Eq. (3) on the normalised target surface."""
            return surface_registration_error(
                mapped,
                pb["uv"],
                pb["Vn"],
                F,
                pb["lm_points"],
                locator=loc,  # type: ignore[arg-type]
            )

        # the paper's MT and DMT (landmarks only): fitted, and k-fold cross-validated
        cv = {}
        for method in ("mt", "dmt"):
            c = cross_validate_registration(
                P, Q, pa["uv"], F, method=method, folds=folds, kernel_scale=scale
            )
            cv[method] = {
                "E_D_fitted": c.E_D_fitted,
                "E_fitted": E(c.fitted_uv),
                "E_D_held_out": c.E_D_held_out,
                "E_held_out": E(c.held_out_uv),
                "folded_fitted": c.folded_triangles_fitted,
                "folded_folds_max": max(c.folded_triangles),
                "fallbacks": c.fallbacks,
            }
        # dense error against the known correspondence (same vertex ids): an evaluation
        # only (the registrations above never see it)
        dense = {}
        for k in ("mt", "dmt"):
            r = register_disk_landmarks(P, Q, pa["uv"], F, method=k, kernel_scale=scale)
            z = r.apply(pa["uv"])
            X = loc_b.locate(z).interpolate(F, pb["Vn"])
            dense[k] = {
                "disk_rms": float(np.sqrt(np.mean(np.sum((z - pb["uv"]) ** 2, axis=1)))),
                "surface_rms": float(np.sqrt(np.mean(np.sum((X - pb["Vn"]) ** 2, axis=1)))),
            }
        rows.append(
            {
                "pair": name,
                "folds": folds,
                "paper": cv,
                "pipeline_default": {
                    "E_D": pm["E_D"],
                    "E": pm["E"],
                    "folded": pm["folded_triangles"],
                    "min_jacobian": pm["min_jacobian"],
                    "fallback": pm["dmt_fallback"],
                },
                "dense": dense,
            }
        )
    return rows


def print_table2(rows: list[dict]) -> None:
    k = rows[0]["folds"]
    print("\nTable 2 analogue (ICT, 68 landmarks, surfaces normalised to diameter 1)")
    print(
        f"MT vs the paper's DMT (landmarks only). 'fitted': at the landmarks the map was fitted "
        f"to (DMT interpolates them: ~0 by construction); 'held-out': {k}-fold cross-validation "
        "(each landmark mapped by the fit that did not see it)"
    )
    hdr = f"{'pair':<17}{'measure':<14}{'MT':>11}{'DMT':>11}{'reduction':>11}"
    print(hdr)
    for r in rows:
        c = r["paper"]
        for label, key in (
            ("E_D fitted", "E_D_fitted"),
            ("E fitted", "E_fitted"),
            ("E_D held-out", "E_D_held_out"),
            ("E held-out", "E_held_out"),
        ):
            mt, dmt = c["mt"][key], c["dmt"][key]
            print(f"{r['pair']:<17}{label:<14}{mt:>11.3e}{dmt:>11.3e}{1 - dmt / mt:>11.0%}")
        d = r["dense"]
        print(
            f"{r['pair']:<17}{'dense 3D rms':<14}{d['mt']['surface_rms']:>11.3e}"
            f"{d['dmt']['surface_rms']:>11.3e}{1 - d['dmt']['surface_rms'] / d['mt']['surface_rms']:>11.0%}"
            "   (every vertex vs the known correspondence; evaluation only)"
        )
        print(
            f"{r['pair']:<17}folded triangles: DMT fitted {c['dmt']['folded_fitted']}, "
            f"worst fold {c['dmt']['folded_folds_max']} (fallbacks {sorted(set(map(str, c['dmt']['fallbacks'])))}); "
            f"pipeline default DMT {r['pipeline_default']['folded']['dmt']}, "
            f"min Jacobian {r['pipeline_default']['min_jacobian']['dmt']:.2f}"
        )
    print("(paper, Table 2, fitted: E_D 1.256e-1 → 6.917e-2 (−45%), E 1.264e-1 → 8.280e-2 (−34%))")


# --------------------------------------------------------------------------- Table 3


def _blend(N, S, J, a, b):
    return N + a * (S - N) + b * (J - N)


PATHS = {
    "curved": (lambda t: t * (2 - t), lambda t: t * t / 4),
    "linear": (lambda t: t / 2, lambda t: 0.0 * t),
}


def table3_keys(path: str) -> tuple:
    """Table 3's key meshes and truths on ``path``: the ICT faces' shared faces ``F``,
    the key times, the truth times, the three key vertex arrays and the
    ``(t, V, F)`` truths."""
    N, F = _load("ict_generic_neutral.obj")
    S, _ = _load("ict_generic_smile.obj")
    J, _ = _load("ict_generic_jawOpen.obj")
    wa, wb = PATHS[path]
    key_t = np.array([0.0, 1.0, 2.0])
    truth_t = [0.3, 0.5, 1.3, 1.5]
    keys = [_blend(N, S, J, wa(t), wb(t)) for t in key_t]
    truths = [(t, _blend(N, S, J, wa(t), wb(t)), F) for t in truth_t]
    return F, key_t, truth_t, keys, truths


def table3(path: str, curvatures: tuple[str, ...]) -> dict:
    lm = _landmarks()
    F, key_t, truth_t, keys, truths = table3_keys(path)
    results: dict = {"truth_times": truth_t}
    # same connectivity (identity oracle)
    prep_same = [prepare_mesh(keys[i], F, lm, mesh_index=i) for i in range(3)]
    # different connectivity: key 1 subdivided, key 2 reordered
    V1s, F1s = subdivide(keys[1], F)
    V2r, F2r, inv = reorder(keys[2], F)
    prep_diff = [
        prep_same[0],
        prepare_mesh(V1s, F1s, lm, mesh_index=1),
        prepare_mesh(V2r, F2r, [int(inv[j]) for j in lm], mesh_index=2),
    ]
    inputs_same = [(k, F) for k in keys]
    inputs_diff = [(keys[0], F), (V1s, F1s), (V2r, F2r)]
    reg_id = register_meshes(prep_same, RegistrationOptions(method="identity", baselines=False))
    reg_d = register_meshes(prep_diff, RegistrationOptions())  # default: refine="auto"
    reg_g = register_meshes(prep_diff, RegistrationOptions(baselines=False, refine="guided"))
    reg_s = register_meshes(prep_diff, RegistrationOptions(baselines=False, refine="none"))
    # evaluation ceiling, not a registration method: DMT given 1000 exact correspondences
    # per pair (known here because the keys come from one rig), to separate what the
    # pipeline loses to the registration's information from what it loses elsewhere
    from conformorph.geometry.static_correspondences import farthest_point_samples

    n0 = keys[0].shape[0]
    inner = np.flatnonzero(np.linalg.norm(prep_same[0]["uv"], axis=1) < 0.95)
    ids0 = farthest_point_samples(prep_same[0]["Vn"], 1000, candidates=inner)
    ids1 = farthest_point_samples(prep_diff[1]["Vn"][:n0], 1000, candidates=inner)
    exact = [
        (prep_diff[0]["uv"][ids0], prep_diff[1]["uv"][ids0]),  # subdivision keeps vertex ids
        (prep_diff[1]["uv"][ids1], prep_diff[2]["uv"][inv[ids1]]),  # reordering: j → inv[j]
    ]
    reg_o = register_meshes(
        prep_diff, RegistrationOptions(baselines=False), extra_correspondences=exact
    )
    for curv in curvatures:
        t0 = time.perf_counter()
        fo = FrameOptions(curvature=curv, key_metrics=False)
        fr_id = compute_frames(reg_id, inputs_same, key_t, key_t, fo, truths=truths)
        fr_d = compute_frames(reg_d, inputs_diff, key_t, key_t, fo, truths=truths)
        fr_s = compute_frames(reg_s, inputs_diff, key_t, key_t, fo, truths=truths)
        fr_g = compute_frames(reg_g, inputs_diff, key_t, key_t, fo, truths=truths)
        fr_o = compute_frames(reg_o, inputs_diff, key_t, key_t, fo, truths=truths)
        te = fr_d["meta"]["truth_errors"]
        results[curv] = {
            "identity": [e["L2"] for e in fr_id["meta"]["truth_errors"]["identity"]],
            "dmt": [e["L2"] for e in te["dmt"]],
            "dmt_paper": [e["L2"] for e in fr_s["meta"]["truth_errors"]["dmt"]],
            "dmt_guided": [e["L2"] for e in fr_g["meta"]["truth_errors"]["dmt"]],
            "guided_folds": reg_g["meta"]["composite_folded_triangles"],
            "refine_used": reg_d["meta"]["refine"]["used"],
            "dmt_exact_ceiling": [e["L2"] for e in fr_o["meta"]["truth_errors"]["dmt"]],
            "mt": [e["L2"] for e in te["mt"]],
            "linear": [e["L2"] for e in te["linear"]],
            "dmt_folds": reg_d["meta"]["composite_folded_triangles"],
            "fallbacks": [p["dmt_fallback"] for p in reg_d["meta"]["pairs"]],
            "static": [
                (p["static_correspondences"], p["static_refinement_rejected"])
                for p in reg_g["meta"]["pairs"]
            ],
            "nicp": [(p["nicp"] or {}).get("correspondences") for p in reg_d["meta"]["pairs"]],
            "seconds": time.perf_counter() - t0,
        }
    return results


def print_table3(path: str, res: dict) -> None:
    tt = res["truth_times"]
    for curv in ("metric", "screened", "vector", "scalar"):
        if curv not in res:
            continue
        r = res[curv]
        print(
            f"\nTable 3 analogue — path '{path}', curvature homotopy '{curv}' "
            "(relative L2 distance to the true surface)"
        )
        print(
            f"{'t':>5}{'identity':>11}{'DMT':>11}{'MT':>11}{'linear':>11}{'DMT(paper)':>11}"
            f"{'DMT/id':>8}{'excess removed':>16}{'Rate_t (4)':>12}{'ceiling':>11}{'ceil/id':>8}"
            f"{'DMT(guided)':>12}{'guided/id':>10}"
        )
        for k, t in enumerate(tt):
            i, d, m, li = r["identity"][k], r["dmt"][k], r["mt"][k], r["linear"][k]
            ds = r["dmt_paper"][k]
            ce = r["dmt_exact_ceiling"][k]
            dg = r["dmt_guided"][k]
            removed = (m - d) / (m - i) if m > i else float("nan")
            print(
                f"{t:>5}{i:>11.3e}{d:>11.3e}{m:>11.3e}{li:>11.3e}{ds:>11.3e}{d / i:>8.2f}"
                f"{removed:>16.0%}{(m - d) / m:>12.0%}{ce:>11.3e}{ce / i:>8.2f}"
                f"{dg:>12.3e}{dg / i:>10.2f}"
            )
        print(
            f"  DMT (refine={r['refine_used']}) folds per key: {r['dmt_folds']}, fallbacks: "
            f"{r['fallbacks']}, non-rigid ICP correspondences per pair: {r['nicp']}; "
            f"DMT(guided) folds per key: {r['guided_folds']}, its extra correspondences "
            f"(accepted, rejected) per pair: {r['static']}; {r['seconds']:.1f} s"
        )
        print(
            "  ceiling: DMT given 1000 exact correspondences per pair besides the landmarks "
            "(an evaluation of what the registration's information costs, not a method)"
        )
    if path == "linear":
        print(
            "  note: this path is linear in vertex space, so linear interpolation is exact by construction"
        )


# --------------------------------------------------------------------------- landmark variants

#: Multi-PIE ids (0-based) of the 5-landmark variant: inner eye corners, nose tip, mouth corners
FIVE_LANDMARKS = (39, 42, 30, 48, 54)
LANDMARK_VARIANTS = ("exact", "perturbed", "five", "auto")


def _perturbed_ids(V: np.ndarray, lm: list[int], sigma: float, seed: int) -> list[int]:
    """The landmark vertices moved by N(0, σ²) per axis, snapped to the nearest vertex."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    moved = V[lm] + rng.normal(0.0, sigma, (len(lm), 3))
    return [int(j) for j in cKDTree(V).query(moved)[1]]


def variant_inputs(
    variant: str, keys: list, F: np.ndarray, inputs_diff: list, inv: np.ndarray
) -> tuple[list, list]:
    """Landmark entries and confidences of the three Table 3 keys for one variant.

    ``exact``: the 68 ICT ids; ``perturbed``: each key's own 68 moved by 3 mm rms per
    axis (seeded, snapped to its vertices); ``five``: 5 of the 68; ``auto``: the
    detector's 68 surface points and confidences on each key (its own connectivity).
    """
    lm = _landmarks()
    mm = float(np.linalg.norm(keys[0][lm[36]] - keys[0][lm[45]])) / 89.2  # ICT outer eyes
    conf = [None, None, None]
    if variant == "exact":
        ids = [lm, lm, lm]
    elif variant == "perturbed":
        ids = [_perturbed_ids(keys[i], lm, 3.0 * mm, seed=10 + i) for i in range(3)]
    elif variant == "five":
        ids = [[lm[j] for j in FIVE_LANDMARKS]] * 3
    elif variant == "auto":
        from conformorph.pipelines.landmark_detection.detect import detect_landmarks

        found = [detect_landmarks(V, Fk) for V, Fk in inputs_diff]
        return [d.points.tolist() for d in found], [d.confidence for d in found]
    else:
        raise ValueError(f"unknown landmark variant {variant!r}")
    return [ids[0], ids[1], [int(inv[j]) for j in ids[2]]], conf


def table3_landmarks(path: str, variants: tuple[str, ...], fits: tuple[str, ...]) -> dict:
    """Table 3 (different connectivity, default DMT, screened homotopy) per landmark variant
    and landmark fit: the error at every truth time."""
    F, key_t, truth_t, keys, truths = table3_keys(path)
    V1s, F1s = subdivide(keys[1], F)
    V2r, F2r, inv = reorder(keys[2], F)
    inputs_diff = [(keys[0], F), (V1s, F1s), (V2r, F2r)]
    res: dict = {"truth_times": truth_t, "errors": {}, "pairs": {}, "seconds": {}}
    fo = FrameOptions(key_metrics=False)
    for variant in variants:
        entries, conf = variant_inputs(variant, keys, F, inputs_diff, inv)
        prep = [
            prepare_mesh(V, Fk, entries[i], mesh_index=i, landmark_confidence=conf[i])
            for i, (V, Fk) in enumerate(inputs_diff)
        ]
        for fit in fits:
            t0 = time.perf_counter()
            reg = register_meshes(prep, RegistrationOptions(baselines=False, landmark_fit=fit))
            fr = compute_frames(reg, inputs_diff, key_t, key_t, fo, truths=truths)
            res["errors"][f"{variant}/{fit}"] = [e["L2"] for e in fr["meta"]["truth_errors"]["dmt"]]
            res["pairs"][f"{variant}/{fit}"] = [
                (p["dmt_fallback"], (p["nicp"] or {}).get("correspondences"))
                for p in reg["meta"]["pairs"]
            ]
            res["seconds"][f"{variant}/{fit}"] = time.perf_counter() - t0
    return res


def print_landmark_variants(path: str, res: dict) -> None:
    tt = res["truth_times"]
    err = res["errors"]
    print(
        f"\nTable 3 landmark variants — path '{path}', default DMT (refine auto), screened "
        "homotopy, key frames of different connectivity; relative L2 distance to the true "
        "surface, and its ratio to the exact-landmark morph of the same fit (and to today's "
        "exact/exact)"
    )
    print(
        f"{'landmarks/fit':<20}"
        + "".join(f"{'t=' + str(t):>11}{'ratio':>7}{'/today':>7}" for t in tt)
    )
    today = err.get("exact/exact")
    for name, e in err.items():
        ref = err.get("exact/" + name.split("/")[1])
        row = f"{name:<20}"
        for k in range(len(tt)):
            r = e[k] / ref[k] if ref else float("nan")
            r0 = e[k] / today[k] if today else float("nan")
            row += f"{e[k]:>11.3e}{r:>7.2f}{r0:>7.2f}"
        print(row + f"   ({res['seconds'][name]:.1f} s; pairs {res['pairs'][name]})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--quick", action="store_true", help="metric and screened homotopies, curved path only"
    )
    ap.add_argument("--table3-only", action="store_true", help="skip Table 2")
    ap.add_argument("--folds", type=int, default=10, help="Table 2 cross-validation folds")
    ap.add_argument("--table2-only", action="store_true", help="skip Table 3")
    ap.add_argument(
        "--landmark-variants",
        action="store_true",
        help="only the Table 3 landmark variants (exact, 3 mm perturbed, 5, auto-detected)",
    )
    ap.add_argument(
        "--variants", default=",".join(LANDMARK_VARIANTS), help="landmark variants to run"
    )
    ap.add_argument("--fits", default="exact,tolerant", help="landmark fits to run")
    ap.add_argument("--json", type=Path, help="also write all figures to this JSON file")
    args = ap.parse_args()
    if not FACES.exists():
        sys.exit(f"shared data not found at {FACES}")
    out: dict = {}
    t = time.perf_counter()
    if args.landmark_variants:
        lv = table3_landmarks(
            "curved", tuple(args.variants.split(",")), tuple(args.fits.split(","))
        )
        print_landmark_variants("curved", lv)
        if args.json:
            args.json.write_text(json.dumps(lv, indent=1))
        return
    if not args.table3_only:
        out["table2"] = table2(folds=args.folds)
        print_table2(out["table2"])
        print(f"  ({time.perf_counter() - t:.1f} s)")
    curvs = ("metric", "screened") if args.quick else ("metric", "screened", "vector", "scalar")
    paths = ("curved",) if args.quick else ("curved", "linear")
    for p in () if args.table2_only else paths:
        out[f"table3_{p}"] = table3(p, curvs)
        print_table3(p, out[f"table3_{p}"])
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
