"""An evaluation corpus of faces nobody here prepared, with known truth (issue 27).

Run (``CONFORMORPH_SHARED_FACES`` names the faces folder when it is not
``../shared/data/faces``)::

    .venv/bin/python benchmarks/face_corpus.py [--list] [--write DIR] [--split tune|report]

Every case is generated on the fly from ``../shared/data/faces`` (nothing is stored),
from a fixed seed, so the corpus is the same on every machine. A case is two or three
key meshes, a landmark file and, for every key, its *truth*: the surface the key was
made from, on one parametrisation shared by all keys of the case, in the key's own
coordinates. A point of key 0 located on truth 0 by barycentric coordinates in a truth
triangle belongs, on key k, at the same barycentric coordinates of the same triangle of
truth k. That gives every morph a per-vertex correspondence error, beside the surface
distance (``benchmarks/bench_face_corpus.py``).

Classes (see :data:`CLASSES`):

* ``ict_pair``: a new ICT identity (a random blend of the kit's three identity
  offsets, ``sample``, ``rand1``, ``rand2``, coefficients in [−0.4, 1.1]: none of the
  faces ``scripts/calibrate_landmarks.py`` calibrated on) with random expression
  weights, to another; the target reordered and turned 20–60°; 68 exact landmarks.
* ``model3k``: a face *model of another source*: one new identity decimated to
  3–5k vertices (``fast_simplification``: its own triangulation), the mouth fill cut
  away (an open mouth, the lips cut along the lip line), in mm; 50 of the 68 points
  given as the nearest model vertex (the model authors' annotation on a coarse mesh);
  three keys along a path (an expression change with the jaw open, a 40–60° turn, a
  drift), key 1 subdivided, key 2 reordered. The failures issue 27 lists come from
  this class.
* ``ict_dense``: one key subdivided twice (111k vertices), the other reordered.
* ``ict_retri``: keys of different connectivity: the target re-triangulated by random
  edge flips and reordered.
* ``ict_subset51`` / ``ict_subset5``: only the inner 51 (ibug 17–67) or 5 points
  (inner eye corners 39, 42, nose tip 30, mouth corners 48, 54) given.
* ``ict_open60``: jaw open + smile + blink (closed eyes), mouth fill cut away, turned 60°.
* ``ict_graded``: an ``ict_pair`` whose meshes are, at one random spot, 1e4 times finer
  (a vertex's one-ring shrunk to 1e-4 of its size in both keys: clean, unevenly graded;
  the class of issue 27's qdldl "numerically singular" refusal).
* ``choi_warp`` / ``meshmonk_warp``: ``choi_human_face`` (m) and a MeshMonk face (mm)
  deformed by a smooth known warp (Gaussian radial displacements, up to 6 % of the
  diameter), turned and reordered (30 farthest-point landmarks on Choi's face, which
  has none; MeshMonk's own 5).

Units vary per case (mm, cm, m: ICT is in cm); ``mm_per_unit`` converts errors to mm.

Split: inside every class the cases are shuffled with :data:`SPLIT_SEED` and dealt
alternately to ``tune`` and ``report``, *before any tuning*; the report part is fixed
here and never changes to make a figure pass.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

#: The shared faces beside the repository, or ``$CONFORMORPH_SHARED_FACES``.
FACES = Path(os.environ.get("CONFORMORPH_SHARED_FACES", ROOT.parent / "shared" / "data" / "faces"))

#: The seed of the tune/report split (fixed before any tuning, never changed).
SPLIT_SEED = 20261207
#: ICT identity offsets and expression blend shapes the new faces are made of.
IDENTITIES = ("sample", "rand1", "rand2")
EXPRESSIONS = ("jawOpen", "smile", "blink", "surprise", "pucker", "sad")
#: Millimetres per unit, and the factor from ICT's cm.
UNITS = {"mm": (1.0, 10.0), "cm": (10.0, 1.0), "m": (1000.0, 0.01)}
#: ibug (Multi-PIE 68) subsets, 0-based.
INNER51 = tuple(range(17, 68))
FIVE = (39, 42, 30, 48, 54)
#: Cases per class (half of each, rounded down, goes to the report part).
CLASSES = {
    "ict_pair": 6,
    "model3k": 6,
    "ict_dense": 2,
    "ict_retri": 2,
    "ict_subset51": 2,
    "ict_subset5": 2,
    "ict_open60": 2,
    "choi_warp": 2,
    "meshmonk_warp": 2,
    "ict_graded": 2,  # added after the first report: appended, so no other case changes
}


@dataclass
class Key:
    """One key mesh of a case with its truth.

    Attributes
    ----------
    V : (n, 3) float64, F : (k, 3) int64
        The key as written.
    truth_V : (n0, 3) float64
        The truth surface in the key's coordinates (the case's shared ``truth_F``).
    landmarks : list
        Landmark entries (vertex ids of V) for the landmark file.
    """

    V: np.ndarray
    F: np.ndarray
    truth_V: np.ndarray
    landmarks: list[int]


@dataclass
class Case:
    """A corpus case: keys, the shared truth triangles, units and split."""

    name: str
    cls: str
    split: str
    keys: list[Key]
    truth_F: np.ndarray
    mm_per_unit: float
    units: str
    landmark_indices: list[int] | None = None
    notes: dict[str, object] = field(default_factory=dict)

    def write(self, folder: Path) -> tuple[list[Path], Path]:
        """Write the keys (OBJ) and the landmark file into ``folder``; return their paths."""
        from conformorph.pipelines.mesh_io import write_obj

        folder.mkdir(parents=True, exist_ok=True)
        paths = []
        for i, k in enumerate(self.keys):
            p = folder / f"{self.name}_key{i}.obj"
            write_obj(p, k.V, k.F)
            paths.append(p)
        doc: dict[str, object] = {"landmarks": [k.landmarks for k in self.keys]}
        if self.landmark_indices is not None:
            doc["indices"] = self.landmark_indices
        lm = folder / f"{self.name}_landmarks.json"
        lm.write_text(json.dumps(doc))
        return paths, lm


# --------------------------------------------------------------------------- sources


def _read(name: str) -> tuple[np.ndarray, np.ndarray]:
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(FACES / name)
    return np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)


_ICT: dict[str, np.ndarray] = {}


def ict(name: str) -> np.ndarray:
    """Vertices of ``ict_<name>.obj`` (cached)."""
    if name not in _ICT:
        _ICT[name] = _read(f"ict_{name}.obj")[0]
    return _ICT[name]


def ict_faces() -> np.ndarray:
    return _read("ict_generic_neutral.obj")[1]


def ict_landmarks() -> np.ndarray:
    d = json.loads((FACES / "ict_landmarks68.json").read_text())
    return np.asarray(d["landmarks_multipie68_0based"], dtype=np.int64)


def ict_blend(identity: np.ndarray, expression: np.ndarray) -> np.ndarray:
    """The ICT linear model: generic + Σ c_i (identity_i − generic) + Σ w_e (expr_e − generic)."""
    g = ict("generic_neutral")
    V = g.copy()
    for c, name in zip(identity, IDENTITIES, strict=True):
        V += c * (ict(f"{name}_neutral") - g)
    for w, name in zip(expression, EXPRESSIONS, strict=True):
        V += w * (ict(f"generic_{name}") - g)
    return V


def mouth_fill_faces(F: np.ndarray) -> np.ndarray:
    """Indices of the ICT faces filling the mouth loop (the 74-vertex inner loop)."""
    from conformorph.geometry.boundary_loop import boundary_loops

    orig = F[:13120]
    loops = boundary_loops(orig)
    mouth = next(lp for lp in loops if len(lp) == 74)
    fill = np.arange(13120, F.shape[0])
    member = np.zeros(F.max() + 1, dtype=bool)
    member[np.asarray(mouth)] = True
    chosen = fill[member[F[fill]].any(axis=1)]
    reach = np.zeros_like(member)
    while True:  # flood through fill vertices (ids ≥ 6706)
        reach[F[chosen].ravel()] = True
        reach[:6706] = False
        grown = fill[member[F[fill]].any(axis=1) | reach[F[fill]].any(axis=1)]
        if grown.size == chosen.size:
            return chosen
        chosen = grown


def rotation(angle_deg: float, axis: np.ndarray) -> np.ndarray:
    a = np.deg2rad(angle_deg)
    k = axis / np.linalg.norm(axis)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * Kx + (1 - np.cos(a)) * Kx @ Kx


def subdivide(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """1→4 midpoint subdivision (the surface is unchanged, vertex ids kept)."""
    from benchmarks.bench_face_tables import subdivide as sub

    return sub(V, F)


def reorder(V: np.ndarray, F: np.ndarray, rng: np.random.Generator) -> tuple:
    """Random vertex permutation; returns (V', F', old→new id map)."""
    perm = rng.permutation(V.shape[0])
    inv = np.argsort(perm)
    return V[perm], inv[F], inv


def flip_edges(V: np.ndarray, F: np.ndarray, rng: np.random.Generator, fraction: float = 0.3):
    """Re-triangulate by flipping a random ``fraction`` of interior edges (one flip per
    triangle, only where both new triangles keep the old orientation)."""
    F = F.copy()
    n = V.shape[0]
    he = {}
    for f, (a, b, c) in enumerate(F):
        for u, v in ((a, b), (b, c), (c, a)):
            he[(int(u), int(v))] = f
    used = np.zeros(F.shape[0], dtype=bool)
    edges = [(u, v) for (u, v) in he if u < v and (v, u) in he]
    existing = {(min(u, v), max(u, v)) for (u, v) in he}
    for i in rng.permutation(len(edges))[: int(fraction * len(edges))]:
        u, v = edges[i]
        f, g = he[(u, v)], he[(v, u)]
        if used[f] or used[g]:
            continue
        a = int(next(x for x in F[f] if x not in (u, v)))
        b = int(next(x for x in F[g] if x not in (u, v)))
        if (min(a, b), max(a, b)) in existing or a == b:
            continue
        t1, t2 = np.array([a, b, v]), np.array([b, a, u])  # (u,v,a) and (v,u,b) → these
        n_old = np.cross(V[F[f][1]] - V[F[f][0]], V[F[f][2]] - V[F[f][0]])
        ok = True
        for t in (t1, t2):
            nt = np.cross(V[t[1]] - V[t[0]], V[t[2]] - V[t[0]])
            c = nt @ n_old / max(np.linalg.norm(nt) * np.linalg.norm(n_old), 1e-300)
            ok &= c > 0.7
        if not ok:
            continue
        F[f], F[g] = t1, t2
        used[f] = used[g] = True
        existing.add((min(a, b), max(a, b)))
    assert F.max() < n
    return F


def smooth_warp(V: np.ndarray, rng: np.random.Generator, amplitude: float = 0.06) -> np.ndarray:
    """A smooth known warp: 6 Gaussian radial displacements (width 0.3 diameter, each at
    most ``amplitude`` × diameter), evaluated at ``V`` (n, 3)."""
    diam = float(np.linalg.norm(np.ptp(V, axis=0)))
    out = V.copy()
    for c in V[rng.choice(V.shape[0], 6, replace=False)]:
        a = rng.normal(size=3)
        a *= amplitude * diam * rng.uniform(0.4, 1.0) / np.linalg.norm(a)
        out += a * np.exp(-np.sum((V - c) ** 2, axis=1) / (2 * (0.3 * diam) ** 2))[:, None]
    return out


def _place(V: np.ndarray, R: np.ndarray, t: np.ndarray, s: float) -> np.ndarray:
    c = V.mean(axis=0)
    return s * ((V - c) @ R.T + c + t)


# --------------------------------------------------------------------------- cases


@dataclass(frozen=True)
class CaseSpec:
    """A case's name, class, index in its class and split (cheap: nothing is built)."""

    name: str
    cls: str
    index: int
    split: str


def corpus_specs() -> list[CaseSpec]:
    """Every case of the corpus with its split (fixed by :data:`SPLIT_SEED`)."""
    specs = []
    for ci, (cls, count) in enumerate(CLASSES.items()):
        order = np.random.default_rng([SPLIT_SEED, ci]).permutation(count)
        report = {int(i) for i in order[: count // 2]}
        for i in range(count):
            split = "report" if i in report else "tune"
            specs.append(CaseSpec(f"{cls}_{i}", cls, i, split))
    return specs


def _new_identity(rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(-0.4, 1.1, size=len(IDENTITIES))


def _expression(rng: np.random.Generator, count: int = 2, high: float = 0.8) -> np.ndarray:
    w = np.zeros(len(EXPRESSIONS))
    w[rng.choice(len(EXPRESSIONS), count, replace=False)] = rng.uniform(0.2, high, size=count)
    return w


_UP = np.array([0.0, 1.0, 0.0])  # ICT's vertical axis; the face looks along +z


def _turned(rng: np.random.Generator, lo: float, hi: float) -> np.ndarray:
    axis = _UP + 0.3 * rng.normal(size=3)
    return rotation(rng.uniform(lo, hi) * rng.choice([-1.0, 1.0]), axis)


def _ict_pair(spec: CaseSpec, rng: np.random.Generator) -> Case:
    """Two new ICT faces (identity + expression each), the target turned and reordered;
    the class decides the landmark set, the target's connectivity and size."""
    F = ict_faces()
    lm = ict_landmarks()
    units = str(rng.choice(list(UNITS)))
    mm, s = UNITS[units]
    id0 = _new_identity(rng)
    same_identity = spec.cls in ("ict_open60",)
    id1 = id0 if same_identity else _new_identity(rng)
    if spec.cls == "ict_open60":
        e0 = np.zeros(len(EXPRESSIONS))
        e1 = np.zeros(len(EXPRESSIONS))
        e1[[0, 1, 2]] = 1.0  # jaw open, smile, blink
        F = F[np.setdiff1d(np.arange(F.shape[0]), mouth_fill_faces(F))]
    else:
        e0, e1 = _expression(rng), _expression(rng)
    R1 = rotation(60.0, _UP) if spec.cls == "ict_open60" else _turned(rng, 20, 60)
    drift = rng.normal(size=3) * 2.0
    T0 = _place(ict_blend(id0, e0), np.eye(3), np.zeros(3), s)
    T1 = _place(ict_blend(id1, e1), R1, drift, s)
    used = np.unique(F)  # without the mouth fill: compact the vertex ids
    new_id = np.full(T0.shape[0], -1)
    new_id[used] = np.arange(used.size)
    T0, T1, F, lm = T0[used], T1[used], new_id[F], new_id[lm]
    if spec.cls == "ict_graded":  # one spot meshed 1e4 times finer, in both keys
        T0, T1 = _dense_spot(T0, T1, F, lm, rng)
    V0, F0, lm0 = T0, F, lm
    V1, F1 = T1, F
    if spec.cls == "ict_retri":
        F1 = flip_edges(V1, F1, rng)
    if spec.cls == "ict_dense":
        V1, F1 = subdivide(*subdivide(V1, F1))
    V1, F1, old_to_new = reorder(V1, F1, rng)
    lm1 = old_to_new[lm]
    indices: list[int] | None = None
    if spec.cls in ("ict_subset51", "ict_subset5"):
        indices = list(INNER51 if spec.cls == "ict_subset51" else FIVE)
        lm0, lm1 = lm0[indices], lm1[indices]
    keys = [Key(V0, F0, T0, lm0.tolist()), Key(V1, F1, T1, lm1.tolist())]
    notes = {"identity": [id0.tolist(), id1.tolist()], "expression": [e0.tolist(), e1.tolist()]}
    return Case(spec.name, spec.cls, spec.split, keys, F, mm, units, indices, notes)


def _dense_spot(
    T0: np.ndarray, T1: np.ndarray, F: np.ndarray, lm: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """The one-ring of a random interior vertex shrunk to 1e-4 of its size in both keys (a
    clean mesh, unevenly graded: a scan's or a model's densely meshed spot). On main
    25e75ad this stopped the morph with qdldl "numerically singular" (issue 27)."""
    from conformorph.geometry.boundary_loop import boundary_loops

    rim = np.concatenate(boundary_loops(F))
    near_rim = np.unique(F[np.isin(F, rim).any(axis=1)])
    ok = np.setdiff1d(np.arange(min(6706, T0.shape[0])), np.concatenate([near_rim, lm]))
    c = int(rng.choice(ok))
    ring = np.setdiff1d(np.unique(F[(F == c).any(axis=1)]), np.r_[c, lm])
    out = []
    for T in (T0, T1):
        T = T.copy()
        T[ring] = T[c] + 1e-4 * (T[ring] - T[c])
        out.append(T)
    return out[0], out[1]


def _locate(points: np.ndarray, V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from conformorph.geometry.surface_distance import SurfaceDistance, projected_barycentrics

    c, _, tri = SurfaceDistance(V, F).closest_triangles(points, k=8)
    return tri, projected_barycentrics(c, V[F[tri]])


def _model3k(spec: CaseSpec, rng: np.random.Generator) -> Case:
    """A coarse face model of its own triangulation, mouth open, 50 of 68 landmarks as
    model vertices; keys: expression change, a 40–60° turn (subdivided), a drift
    (reordered)."""
    import fast_simplification

    F = ict_faces()
    Fc = F[np.setdiff1d(np.arange(F.shape[0]), mouth_fill_faces(F))]
    used = np.unique(Fc)  # without the mouth fill: compact the vertex ids
    new_id = np.full(F.max() + 1, -1)
    new_id[used] = np.arange(used.size)
    Fc = new_id[Fc]
    units = "mm" if spec.index % 3 else "cm"
    mm, s = UNITS[units]
    ident = _new_identity(rng)
    exprs = [_expression(rng, 1, 0.5), _expression(rng, 2), _expression(rng, 2)]
    exprs[1][0] = max(exprs[1][0], 0.6)  # the jaw opens on the way
    base = ict_blend(ident, np.zeros(len(EXPRESSIONS)))[used]
    target = int(rng.integers(3000, 5000))
    Vd, Fd = fast_simplification.simplify(base, Fc, target_reduction=1.0 - target / used.size)
    Vd = np.asarray(Vd, dtype=np.float64)
    Fd = np.asarray(Fd, dtype=np.int64)
    tri, bc = _locate(Vd, base, Fc)
    lm68 = ict_landmarks()
    near = np.argmin(
        np.linalg.norm(Vd[None, :, :] - base[new_id[lm68]][:, None, :], axis=2), axis=1
    )
    # the authors' 50: points whose nearest model vertex no other point shares
    unique = [i for i in range(68) if np.sum(near == near[i]) == 1]
    indices = sorted(rng.choice(unique, min(50, len(unique)), replace=False).tolist())
    Rs = [np.eye(3), _turned(rng, 40, 60), _turned(rng, 0, 15)]
    drifts = [np.zeros(3), rng.normal(size=3), rng.normal(size=3) * 3.0]
    keys = []
    for k in range(3):
        truth = _place(ict_blend(ident, exprs[k])[used], Rs[k], drifts[k], s)
        Vk = np.einsum("ij,ijk->ik", bc, truth[Fc[tri]])
        Fk, lmk = Fd, near[indices]
        if k == 1:
            Vk, Fk = subdivide(Vk, Fk)
        if k == 2:
            Vk, Fk, old_to_new = reorder(Vk, Fk, rng)
            lmk = old_to_new[lmk]
        keys.append(Key(Vk, Fk, truth, lmk.tolist()))
    notes = {"model_vertices": int(Vd.shape[0]), "identity": ident.tolist()}
    return Case(spec.name, spec.cls, spec.split, keys, Fc, mm, units, indices, notes)


def _warped(spec: CaseSpec, rng: np.random.Generator) -> Case:
    """A Choi or MeshMonk face and the same face under a smooth known warp, turned,
    drifted and reordered."""
    from conformorph.geometry.static_correspondences import farthest_point_samples

    if spec.cls == "choi_warp":
        V, F = _read("choi_human_face.obj")
        units, mm = "m", 1000.0
        lm = np.asarray(
            farthest_point_samples(
                V, 30, candidates=np.roll(np.arange(V.shape[0]), -spec.index * 997)
            ),
            dtype=np.int64,
        )
    else:
        V, F = _read(f"meshmonk_SIMPOP_0{1 + spec.index}.obj")
        units, mm = "mm", 1.0
        d = json.loads((FACES / "meshmonk_landmarks.json").read_text())
        lm = np.asarray(d["nearest_vertex_0based"], dtype=np.int64)
    axis = np.array([0.0, 1.0, 0.0]) + 0.3 * rng.normal(size=3)
    W = smooth_warp(V, rng)
    diam = float(np.linalg.norm(np.ptp(V, axis=0)))
    T1 = _place(W, rotation(rng.uniform(20, 45), axis), 0.05 * diam * rng.normal(size=3), 1.0)
    V1, F1, old_to_new = reorder(T1, F, rng)
    keys = [Key(V, F, V, lm.tolist()), Key(V1, F1, T1, old_to_new[lm].tolist())]
    return Case(spec.name, spec.cls, spec.split, keys, F, mm, units, None, {})


def build_case(spec: CaseSpec) -> Case:
    """Generate one case (deterministic: seeded by the split seed, class and index)."""
    ci = list(CLASSES).index(spec.cls)
    rng = np.random.default_rng([SPLIT_SEED, ci, spec.index, 1])
    if spec.cls == "model3k":
        return _model3k(spec, rng)
    if spec.cls in ("choi_warp", "meshmonk_warp"):
        return _warped(spec, rng)
    return _ict_pair(spec, rng)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--list", action="store_true", help="list the cases and their split")
    ap.add_argument("--split", choices=["tune", "report", "all"], default="all")
    ap.add_argument("--only", nargs="*", help="case names")
    ap.add_argument("--write", metavar="DIR", help="write the keys and landmark files")
    args = ap.parse_args(argv)
    specs = [s for s in corpus_specs() if args.split in ("all", s.split)]
    if args.only:
        specs = [s for s in specs if s.name in args.only]
    for s in specs:
        if args.write:
            case = build_case(s)
            paths, lm = case.write(Path(args.write))
            sizes = [k.V.shape[0] for k in case.keys]
            print(f"{s.name:18s} {s.split:6s} {case.units:2s} vertices {sizes} -> {lm}")
        else:
            print(f"{s.name:18s} {s.split}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
