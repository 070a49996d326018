"""Scan-like inputs made from the shared faces, each morphed with ``--prepare auto`` alone.

Run::

    .venv/bin/python benchmarks/bench_scan_inputs.py [--variants all|fragment,holes,…] [--json]
    .venv/bin/python benchmarks/bench_scan_inputs.py --scale

``--scale`` times the preparation step alone (:func:`conformorph.pipelines.preparation.prepare_mesh_arrays`,
the median of 3) on ``choi_mcq_face1_holes`` (14k vertices, three holes) and on it
subdivided once (56k) and twice (220k), and prints the holes filled and vertices added;
then the same on the closed head of ``closed`` (10k, 41k, 163k vertices; the face cut
placed by the landmarks).

The clean pair is ``ict_generic_neutral`` → ``ict_generic_smile`` (7k vertices, the
shared 68 landmarks as vertex ids). Each variant corrupts both keys the way raw scans
are corrupt (a different seed per key) and writes a landmark file whose ids follow the
corrupted vertex order:

- ``fragment``: a floating piece (a copy of a 300-vertex patch, shifted off the face);
- ``holes``: three holes cut away from the landmarks (radius 1 %, 2.5 % and 5 % of the
  face's diagonal);
- ``unreferenced``: 200 vertices used by no face, inserted at random rows (every id after
  them shifts, the landmark file with them);
- ``duplicates``: 5 % of the faces repeated (half reversed) and 1 % degenerate faces
  (a repeated corner), at random rows;
- ``noise``: Gaussian noise of 0.02 % of the diagonal on every vertex;
- ``subdivision_1m``: each key at a scanner's resolution: midpoint subdivisions until it
  has at least a million vertices (four: 1.78M; the surface and the landmark ids
  unchanged); the preparation decimates it to its vertex budget and the frames are
  compared at that resolution. (Three subdivisions and random faces split at their
  centroid up to exactly 1,000,000 made fast-simplification stop at 423k vertices for a
  target of 50k after 130 s of CPU; a second run on its output reached 108k in 47 s more.
  The preparation now runs it in steps of at most 4x, up to 6 runs
  (``decimation.passes``): a single run on the 1.78M face stalled on its coplanar faces
  and then collapsed edges whatever their error, which made this variant 25.7x; see
  :mod:`conformorph.pipelines.preparation.decimation`.)
- ``subdivision_445k``: three midpoint subdivisions (445,673 vertices: 890k faces, two
  steps to the budget);
- ``closed``: the face closed into a genus-0 head (:func:`close_shell`: a back and a
  neck cut flat, glued onto the face's boundary at a seam; the face's vertex ids kept), so
  the preparation must cut the face out (``face_cut`` in its report);
- ``open_neck``: the same head with the neck's flat cut left open: one boundary loop,
  a disk by topology but a whole head (its loop is short for the area it bounds), cut too;
- ``closed_all``: the three holes of ``holes`` cut (away from the landmarks and the face's
  outline), then the face closed into the head, then noise, a fragment, duplicate and
  unreferenced elements (the hole filling leaves the longest hole; the preparation closes
  it before the cut);
- ``smooth_closed``: the face closed into a head with no crease where the back meets it,
  as on a real scan (:func:`close_shell_smooth`: the back leaves the face along its own
  tangent plane; seam dihedral median 3.3°, max 17.9°, the face's own median 3.1°), so the
  cut cannot follow a seam and must place the face's outline itself;
- ``smooth_open_neck``: the same with the neck's flat cut left open;
- ``all``: every fault above at once (but the 1M subdivision).

Every variant is morphed with the options ``conformorph morph M0 M1 --landmarks L.json
--frame-times 0.25,0.5,0.75`` maps its flags to (``--prepare auto`` is the default;
:func:`conformorph.cli.cmd_morph.morph_options_from_args`), through stage 1 as the command runs it.
Measured: ``e_v(t)``, the surface distance (``L2`` of
:func:`conformorph.geometry.surface_distance.surface_to_surface_error`, relative to the bounding-box
diagonal) of the variant's frame to the clean pair's frame at ``t``, against ``e_c(t)``,
the clean pair's frame to the truth (the ICT blend ``N + t (S - N)``) at the same ``t``;
the target is ``max_t e_v(t) / e_c(t) ≤ 2``. Also printed: the same ratio for the one-sided
distance from the clean frame to the variant's (``L2_backward``): whether all of the face is
there and morphs as the clean pair's, whatever extra surface a face cut kept around it. Needs ``../shared/data/faces``; not part of
the test run.
"""

from __future__ import annotations

import argparse
import json
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

TIMES = (0.25, 0.5, 0.75)
VARIANTS = (
    "fragment",
    "holes",
    "unreferenced",
    "duplicates",
    "noise",
    "closed",
    "open_neck",
    "closed_all",
    "smooth_closed",
    "smooth_open_neck",
    "all",
    "subdivision_1m",
    "subdivision_445k",
)

Mesh = tuple[np.ndarray, np.ndarray, list[int]]


def _diag(V: np.ndarray) -> float:
    return float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))


def add_fragment(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Append a floating copy of a 300-vertex patch, shifted off the face."""
    seed = int(rng.integers(V.shape[0]))
    near = np.argsort(np.linalg.norm(V - V[seed], axis=1))[:300]
    inside = np.isin(F, near).all(axis=1)
    piece = F[inside]
    ids = np.unique(piece)
    remap = np.full(V.shape[0], -1)
    remap[ids] = V.shape[0] + np.arange(ids.size)
    shift = np.array([0.0, 0.0, 0.3 * _diag(V)])
    return np.vstack([V, V[ids] + shift]), np.vstack([F, remap[piece]]), lm


def cut_holes(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Cut three holes (radius 1 %, 2.5 %, 5 % of the diagonal) away from the landmarks and
    the boundary; the vertices left unused are dropped (landmark ids follow)."""
    from conformorph.geometry import mesh_edges

    d = _diag(V)
    boundary = np.unique(mesh_edges(F).boundary)
    keep = np.ones(F.shape[0], dtype=bool)
    taken: list[np.ndarray] = []
    for frac in (0.05, 0.025, 0.01):
        r = frac * d
        far = np.min(np.linalg.norm(V[:, None] - V[lm][None], axis=2), axis=1) > 1.5 * r
        if boundary.size:  # a closed surface has none
            near_b = np.linalg.norm(V[:, None] - V[boundary][None], axis=2)
            far &= np.min(near_b, axis=1) > 2.5 * r
        for c in taken:
            far &= np.linalg.norm(V - c, axis=1) > 2.5 * r + 0.05 * d
        cands = np.flatnonzero(far)
        c = V[int(rng.choice(cands))]
        taken.append(c)
        keep &= np.linalg.norm(V[F].mean(axis=1) - c, axis=1) >= r
    used = np.unique(F[keep])
    remap = np.full(V.shape[0], -1)
    remap[used] = np.arange(used.size)
    return V[used], remap[F[keep]], [int(remap[i]) for i in lm]


def add_unreferenced(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Insert 200 unused vertices at random rows (ids after them shift)."""
    n, k = V.shape[0], 200
    rows = np.sort(rng.choice(n + k, size=k, replace=False))
    is_new = np.zeros(n + k, dtype=bool)
    is_new[rows] = True
    old_to_new = np.flatnonzero(~is_new)
    W = np.zeros((n + k, 3))
    W[old_to_new] = V
    W[rows] = V.mean(axis=0) + rng.normal(scale=0.2 * _diag(V), size=(k, 3))
    return W, old_to_new[F], [int(old_to_new[i]) for i in lm]


def add_duplicates(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Repeat 5 % of the faces (half reversed) and add 1 % degenerate ones, shuffled in."""
    m = F.shape[0]
    dup = F[rng.choice(m, size=m // 20, replace=False)].copy()
    dup[::2] = dup[::2, ::-1]
    deg = F[rng.choice(m, size=m // 100, replace=False)].copy()
    deg[:, 2] = deg[:, 0]
    G = np.vstack([F, dup, deg])
    return V, G[rng.permutation(G.shape[0])], lm


def add_noise(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Gaussian noise of 0.02 % of the diagonal on every coordinate."""
    return V + rng.normal(scale=2e-4 * _diag(V), size=V.shape), F, lm


def subdivide_to_1m(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Midpoint subdivisions until the key has at least 1,000,000 vertices (four for the
    ICT face: 1,784,...; ids kept, new vertices appended; ``rng`` unused)."""
    from benchmarks.bench_face_tables import subdivide

    while V.shape[0] < 1_000_000:
        V, F = subdivide(V, F)
    return V, F, lm


def subdivide_3_times(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Three midpoint subdivisions (445,673 vertices for the ICT face; ids kept)."""
    from benchmarks.bench_face_tables import subdivide

    for _ in range(3):
        V, F = subdivide(V, F)
    return V, F, lm


def close_shell(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """Close the face into a genus-0 head: a back and a neck glued onto its boundary.

    The back is a dome of rings swept from the face's boundary loop to a point behind it
    (the face looks along +z): each ring shrinks toward the face's axis as it goes back,
    so the back meets the face at a seam (a crease of some 40–90°, as where a face scan
    is glued onto a template head); below the chin the rings are pulled down into a neck, cut flat.
    The face's vertices keep their ids; the new ones come after them.
    """
    return _shell(V, F, lm, rng, smooth=False)


def close_shell_smooth(
    V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any, *, rings: int = 24, step: int = 1
) -> Mesh:
    """:func:`close_shell` with no crease where the back meets the face, as on a real scan.

    Each boundary vertex is swept to the point behind the face by a cubic Hermite curve
    that leaves it along the face's outward conormal (the direction in the face's tangent
    plane across the boundary, smoothed along the loop) and arrives level, toward the
    face's axis (:func:`_hermite_back`); below the chin the curves are pulled down into the
    neck from the seam on, smoothly, and cut flat. The back thus leaves the face in its
    tangent plane (on the ICT face the dihedral angle across the seam has median 3.3° and
    maximum 17.9°, against the face's own median 3.1°; :func:`close_shell` 49.7° and 93.6°)
    and bends round evenly (3–9° between rings). ``rings``: rings swept (the point behind
    is the last); ``step``: every ``step``-th boundary vertex starts a curve (the first ring
    zipped to the boundary), for a small fixture. The face's vertices keep their ids.
    """
    return _shell(V, F, lm, rng, smooth=True, rings=rings, step=step)


def _outward_conormals(V: np.ndarray, F: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit vectors (len(b), 3) in the face's tangent plane at each boundary vertex of the
    loop ``b``, across the boundary and away from the face, smoothed along the loop."""
    from conformorph.geometry import mesh_edges

    nxt = np.roll(b, -1)
    E = mesh_edges(F)
    key = {(int(a), int(c)): k for k, (a, c) in enumerate(E.edges)}
    he = E.halfedge_edge.reshape(-1)
    face_of = np.full(E.edges.shape[0], -1)
    face_of[he] = np.repeat(np.arange(F.shape[0]), 3)
    t = np.zeros((b.size, 3))
    for k, (i, j) in enumerate(zip(b, nxt, strict=True)):
        f = F[face_of[key[(min(i, j), max(i, j))]]]
        n = np.cross(V[f[1]] - V[f[0]], V[f[2]] - V[f[0]])
        e = V[j] - V[i]
        c = np.cross(e, n)
        other = V[f[~np.isin(f, [i, j])][0]]
        if c @ (other - V[i]) > 0:
            c = -c
        c /= np.linalg.norm(c)
        t[k] += c  # the edge's conormal to both its ends
        t[(k + 1) % b.size] += c
    for _ in range(4):  # smooth along the loop: boundary triangles are irregular
        t = 0.5 * t + 0.25 * (np.roll(t, 1, axis=0) + np.roll(t, -1, axis=0))
    return t / np.linalg.norm(t, axis=1)[:, None]


def _hermite_back(B: np.ndarray, out: np.ndarray, apex: np.ndarray, s: float) -> np.ndarray:
    """Points (len(B), 3) at ``s`` in [0, 1] of cubic Hermite curves from each boundary point
    (leaving along ``out``, tangent to the face) to ``apex`` (arriving level, toward the
    face's axis): the back leaves the face with no crease and bends round evenly."""
    inward = np.zeros_like(B)
    inward[:, :2] = apex[:2] - B[:, :2]
    chord = np.linalg.norm(apex - B, axis=1)[:, None]
    T0 = chord * out
    T1 = chord * inward / np.maximum(np.linalg.norm(inward, axis=1), 1e-12)[:, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * B + h10 * T0 + h01 * apex + h11 * T1


def _shell(
    V: np.ndarray,
    F: np.ndarray,
    lm: list[int],
    rng: Any,
    *,
    smooth: bool,
    rings: int = 24,
    step: int = 1,
) -> Mesh:
    """The head of :func:`close_shell` (``smooth``: of :func:`close_shell_smooth`)."""
    from conformorph.geometry import MeshError, boundary_loop, split_nonmanifold

    try:
        b = boundary_loop(F, V)
    except MeshError:  # holes cut earlier may touch at a vertex: find the outer loop apart
        s = split_nonmanifold(F, V.shape[0])
        b = s.source[boundary_loop(s.F, V[s.source])]
    B = V[b]
    c = np.array([B[:, 0].mean(), B[:, 1].mean(), B[:, 2].min()])
    height = float(np.ptp(B[:, 1]))
    depth = (1.0 + 0.1 * rng.random()) * float(np.ptp(B[:, 0]))
    floor = B[:, 1].min() - 0.4 * height  # the neck is cut flat there, as scans end
    K, apex = rings, c - [0.0, 0.0, depth]
    pick = np.arange(0, b.size, step)  # the boundary vertices that start a curve
    if smooth:
        out = _outward_conormals(V, F, b)[pick]
    B = B[pick]
    below = np.clip((c[1] - B[:, 1]) / (0.4 * height), 0.0, 1.0)
    loops, W, n = [b], [V], V.shape[0]
    for k in range(1, K):
        phi = 0.5 * np.pi * k / K
        if smooth:
            R = _hermite_back(B, out, apex, k / K)
        else:
            rho = np.cos(phi) * (1.0 - np.sin(phi) * np.exp(-phi / 0.35))
            R = np.empty_like(B)
            R[:, :2] = c[:2] + (B[:, :2] - c[:2]) * rho
            R[:, 2] = B[:, 2] + (c[2] - depth - B[:, 2]) * np.sin(phi)
        # the neck: rings below the chin pulled down (from the seam on, smoothly, when smooth)
        neck = np.sin(np.pi * (k / K if smooth else max(0.0, (k / K - 0.25) / 0.75))) ** 2
        R[:, 1] = np.maximum(R[:, 1] - 1.2 * height * neck * below, floor)
        loops.append(n + np.arange(pick.size))
        W.append(R)
        n += pick.size
    W.append(apex[None])
    tris = [_zip_loops(loops[0], loops[1], pick)]
    for r0, r1 in zip(loops[1:-1], loops[2:], strict=True):
        s0, s1 = np.roll(r0, -1), np.roll(r1, -1)
        tris += [np.c_[s0, r0, r1], np.c_[s0, r1, s1]]
    r = loops[-1]
    tris.append(np.c_[np.roll(r, -1), r, np.full(r.size, n)])
    return np.vstack(W), np.vstack([F, *tris]), lm


def _zip_loops(a: np.ndarray, r: np.ndarray, pick: np.ndarray) -> np.ndarray:
    """Triangles joining the loop ``a`` to the loop ``r`` whose vertex ``i`` starts at
    ``a[pick[i]]`` (``pick`` increasing from 0), oriented as the rings' triangles."""
    q = np.searchsorted(pick, np.arange(a.size), side="right") - 1  # r-vertex of each a
    s0, q1 = np.roll(a, -1), np.roll(q, -1)
    tris = [np.c_[s0, a, r[q]]]
    new = q1 != q  # the a-edge ends where the next r-vertex starts: close that gap
    tris.append(np.c_[s0[new], r[q[new]], r[q1[new]]])
    return np.vstack(tris)


def open_neck_shell(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """:func:`close_shell` with the neck's flat cut left open (one boundary loop around a
    head: a disk by topology, but not a face's outline)."""
    return _open_neck(*close_shell(V, F, lm, rng), F.shape[0])


def open_neck_smooth(V: np.ndarray, F: np.ndarray, lm: list[int], rng: Any) -> Mesh:
    """:func:`close_shell_smooth` with the neck's flat cut left open."""
    return _open_neck(*close_shell_smooth(V, F, lm, rng), F.shape[0])


def _open_neck(W: np.ndarray, G: np.ndarray, lm: list[int], m: int) -> Mesh:
    """The head ``W, G`` without the faces of its flat neck cut (its first ``m`` faces are
    the face's)."""
    floor = W[int(G[:m].max()) + 1 :, 1].min()
    flat = np.isclose(W[G][:, :, 1], floor).all(axis=1)
    flat[:m] = False
    return W, G[~flat], lm


def corrupt(name: str, V: np.ndarray, F: np.ndarray, lm: list[int], seed: int) -> Mesh:
    """The variant ``name`` of one key."""
    rng = np.random.default_rng(seed)
    steps = {
        "fragment": [add_fragment],
        "holes": [cut_holes],
        "unreferenced": [add_unreferenced],
        "duplicates": [add_duplicates],
        "noise": [add_noise],
        "closed": [close_shell],
        "open_neck": [open_neck_shell],
        "smooth_closed": [close_shell_smooth],
        "smooth_open_neck": [open_neck_smooth],
        "closed_all": [
            cut_holes,
            close_shell,
            add_noise,
            add_fragment,
            add_duplicates,
            add_unreferenced,
        ],
        "all": [cut_holes, add_noise, add_fragment, add_duplicates, add_unreferenced],
        "subdivision_1m": [subdivide_to_1m],
        "subdivision_445k": [subdivide_3_times],
    }[name]
    mesh: Mesh = (V, F, lm)
    for step in steps:
        mesh = step(*mesh, rng)
    return mesh


def morph_frames(
    paths: list[Path], lm_path: Path, flags: list[str] | None = None
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Frames at :data:`TIMES` with the options of ``conformorph morph`` (defaults, or
    with ``flags`` added)."""
    from conformorph.cli.cmd_morph import morph_options_from_args
    from conformorph.cli.main import build_parser
    from conformorph.pipelines.face_morph.frames import compute_frames
    from conformorph.pipelines.face_morph.registration import register_meshes
    from conformorph.pipelines.face_morph.run import _prepare_keys

    argv = ["morph", *map(str, paths), "--landmarks", str(lm_path), "-o", "unused"]
    argv += ["--frame-times", ",".join(map(str, TIMES)), *(flags or [])]
    options = morph_options_from_args(build_parser().parse_args(argv))
    prepared = _prepare_keys(paths, lm_path, None, options)
    reg = register_meshes(prepared, options.registration)
    meshes = [(p["V"], p["F"]) for p in prepared]
    fr = compute_frames(reg, meshes, np.array([0.0, 1.0]), np.array(TIMES), options.homotopy)
    meta = [p["meta"].get("preparation", {}) for p in prepared]
    return fr["frames_V"], reg["cm_F"], {"preparation": meta}


def bench_scale() -> None:
    """Seconds of the preparation step on a holed face at three resolutions."""
    import statistics

    from benchmarks.bench_face_tables import subdivide
    from conformorph.pipelines.mesh_io import read_mesh
    from conformorph.pipelines.preparation import prepare_mesh_arrays

    V, F = read_mesh(FACES / "choi_mcq_face1_holes.obj")
    for level in range(3):
        if level:
            V, F = subdivide(V, F)
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            p = prepare_mesh_arrays(V, F)
            times.append(time.perf_counter() - t0)
        r = p.report
        print(
            f"{V.shape[0]} vertices: {statistics.median(times):.2f} s "
            f"(holes {r['filled_holes']}, +{r['added_vertices']} vertices)",
            flush=True,
        )


def bench_scale_closed() -> None:
    """Seconds of the preparation step on the closed head of ``closed`` (landmarks given)."""
    import statistics

    from benchmarks.bench_face_tables import subdivide
    from conformorph.pipelines.mesh_io import read_mesh
    from conformorph.pipelines.preparation import prepare_mesh_arrays

    lm = json.loads((FACES / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    N, F = read_mesh(FACES / "ict_generic_neutral.obj")
    V, G, _ = close_shell(N, F, lm, np.random.default_rng(0))
    for level in range(3):
        if level:
            V, G = subdivide(V, G)  # vertex ids kept: the landmarks stay valid
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            p = prepare_mesh_arrays(V, G, landmark_ids=lm)
            times.append(time.perf_counter() - t0)
        cut = p.report["face_cut"]
        print(
            f"closed head, {V.shape[0]} vertices: {statistics.median(times):.2f} s "
            f"(face cut kept {cut['kept_faces']} of {G.shape[0]} faces)",
            flush=True,
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--variants", default="all-variants")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--scale", action="store_true", help="time the preparation step alone")
    args = ap.parse_args()
    if args.scale:
        bench_scale()
        bench_scale_closed()
        return
    names = list(VARIANTS) if args.variants == "all-variants" else args.variants.split(",")
    from conformorph.geometry.surface_distance import surface_to_surface_error
    from conformorph.pipelines.mesh_io import read_mesh, write_obj

    lm = json.loads((FACES / "ict_landmarks68.json").read_text())["landmarks_multipie68_0based"]
    N, F = read_mesh(FACES / "ict_generic_neutral.obj")
    S, _ = read_mesh(FACES / "ict_generic_smile.obj")
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "clean.json").write_text(json.dumps({"landmarks": [lm, lm]}))
        t0 = time.perf_counter()
        clean_V, clean_F, _ = morph_frames(
            [FACES / "ict_generic_neutral.obj", FACES / "ict_generic_smile.obj"], d / "clean.json"
        )
        clean_s = time.perf_counter() - t0
        e_c = [
            surface_to_surface_error(clean_V[k], clean_F, N + t * (S - N), F)["L2"]
            for k, t in enumerate(TIMES)
        ]
        print(f"clean pair: e_c = {[f'{e:.3g}' for e in e_c]} ({clean_s:.1f} s)", flush=True)
        for name in names:
            keys = [corrupt(name, X, F, lm, seed) for seed, X in enumerate((N, S))]
            paths = [d / f"{name}_{i}.obj" for i in range(2)]
            for p, (V, G, _) in zip(paths, keys, strict=True):
                write_obj(p, V, G)
            (d / f"{name}.json").write_text(json.dumps({"landmarks": [k[2] for k in keys]}))
            t0 = time.perf_counter()
            try:
                Vf, Ff, meta = morph_frames(paths, d / f"{name}.json")
            except Exception as exc:  # noqa: BLE001 - a failure is a result here
                rows.append({"variant": name, "ok": False, "error": f"{type(exc).__name__}: {exc}"})
                print(f"{name}: FAILED {rows[-1]['error']}", flush=True)
                continue
            secs = time.perf_counter() - t0
            errs = [
                surface_to_surface_error(Vf[k], Ff, clean_V[k], clean_F) for k in range(len(TIMES))
            ]
            e_v = [e["L2"] for e in errs]
            ratio = max(v / c for v, c in zip(e_v, e_c, strict=True))
            # the clean face to the variant's frame alone: is all of the face there, morphed
            # as the clean pair's (extra surface kept around it does not count here)
            covered = max(e["L2_backward"] / c for e, c in zip(errs, e_c, strict=True))
            rows.append(
                {
                    "variant": name,
                    "ok": True,
                    "e_v": e_v,
                    "ratio": ratio,
                    "ratio_backward": covered,
                    "L2_forward": [e["L2_forward"] for e in errs],
                    "seconds": secs,
                }
                | meta
            )
            print(
                f"{name}: e_v = {[f'{e:.3g}' for e in e_v]}, max e_v/e_c = {ratio:.2f} "
                f"({'meets' if ratio <= 2 else 'misses'} ≤ 2; clean face to frame alone "
                f"{covered:.2f}; {secs:.1f} s)",
                flush=True,
            )
    if args.json:
        print(json.dumps({"times": TIMES, "e_c": e_c, "variants": rows}, indent=1))


if __name__ == "__main__":
    main()
