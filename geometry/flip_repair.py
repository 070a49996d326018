"""Flip repair of two meshes with the same triangles: edge flips valid in both, kernel-centre relocation."""

from __future__ import annotations

import numpy as np

from ._typing import BoolArray, FloatArray, IntArray


def _areas(V: FloatArray, F: IntArray) -> FloatArray:
    """Signed areas (m,) of triangles ``F`` (m, 3) of points ``V`` (n, 2): half the cross
    product of the edges from corner 0 (gathered per coordinate: fewer numpy calls for
    the small fans the mesh-quality loops pass)."""
    x, y = V[:, 0][F], V[:, 1][F]
    e1x, e1y = x[:, 1] - x[:, 0], y[:, 1] - y[:, 0]
    e2x, e2y = x[:, 2] - x[:, 0], y[:, 2] - y[:, 0]
    return np.asarray(0.5 * (e1x * e2y - e1y * e2x), dtype=np.float64)


def _kernel_center(P: FloatArray, A: FloatArray, B: FloatArray) -> FloatArray | None:
    """Chebyshev centre of {x : x left of every directed edge A_i → B_i}, or None if empty."""
    e = B - A
    nrm = np.c_[-e[:, 1], e[:, 0]]
    ln = np.linalg.norm(nrm, axis=1)
    if np.any(ln == 0):
        return None
    # maximise r subject to  n_i·x − |n_i| r ≥ n_i·a_i
    A_ub = np.c_[-nrm, ln]
    b_ub = -np.einsum("ij,ij->i", nrm, A)
    scale = float(np.ptp(np.vstack([A, B]), axis=0).max()) or 1.0
    # imported here: scipy.optimize costs 0.2-0.35 s of start-up, and a flip repair is rare
    from scipy.optimize import linprog

    res = linprog(
        c=[0.0, 0.0, -1.0],
        A_ub=A_ub,
        b_ub=b_ub,
        bounds=[(None, None), (None, None), (0.0, scale)],
        method="highs",
    )
    if res.status != 0 or res.x[2] <= 1e-12 * scale:
        return None
    return np.asarray(res.x[:2], dtype=np.float64)


def _vertex_faces(F: IntArray, n: int) -> list[list[int]]:
    vf: list[list[int]] = [[] for _ in range(n)]
    for f, tri in enumerate(np.asarray(F).tolist()):
        for v in tri:
            vf[v].append(f)
    return vf


def _one_ring_edges(F: IntArray, faces: list[int], v: int) -> tuple[IntArray, IntArray]:
    """Directed opposite edges (a, b) of v's incident faces, CCW orientation of each face."""
    a, b = [], []
    for f in faces:
        tri = F[f]
        k = int(np.flatnonzero(tri == v)[0])
        a.append(int(tri[(k + 1) % 3]))
        b.append(int(tri[(k + 2) % 3]))
    return np.array(a), np.array(b)


def _relocate(
    V: FloatArray, F: IntArray, vf: list[list[int]], verts: set[int], fixed: BoolArray
) -> FloatArray:
    V = V.copy()
    for v in sorted(verts):
        if fixed[v]:
            continue
        a, b = _one_ring_edges(F, vf[v], v)
        c = _kernel_center(V[v], V[a], V[b])
        if c is not None:
            V[v] = c
    return V


def _edge_flips(Vs: FloatArray, Vt: FloatArray, F: IntArray, bad: IntArray) -> tuple[IntArray, int]:
    """Flip interior edges of bad triangles when both new triangles are positive in both meshes."""
    F = F.copy()
    edge_faces: dict[tuple[int, int], list[int]] = {}
    for f, tri in enumerate(F.tolist()):  # Python ints: no numpy scalar per corner
        for k in range(3):
            a, b = tri[k], tri[(k + 1) % 3]
            edge_faces.setdefault((a, b) if a < b else (b, a), []).append(f)
    done = 0
    touched: set[int] = set()
    for f in bad:
        if f in touched:
            continue
        tri = F[f]
        for k in range(3):
            i, j = int(tri[k]), int(tri[(k + 1) % 3])
            fs = edge_faces.get((min(i, j), max(i, j)), [])
            if len(fs) != 2:
                continue
            g = fs[0] if fs[1] == f else fs[1]
            if g in touched:
                continue
            p = int(tri[(k + 2) % 3])
            other = F[g]
            q = int([x for x in other if x != i and x != j][0])
            n1, n2 = np.array([p, i, q]), np.array([p, q, j])
            ok = True
            for V in (Vs, Vt):
                if _areas(V, np.array([n1, n2])).min() <= 0:
                    ok = False
            if ok:
                F[f], F[g] = n1, n2
                touched.update((f, g))
                done += 1
                break
    return F, done


def repair_flips(
    Xs: FloatArray, Xt: FloatArray, F: IntArray, fixed: BoolArray, repair_rounds: int
) -> tuple[FloatArray, FloatArray, IntArray, int]:
    """Remove what flipped triangles are left: edge flips valid in both meshes, then relocation.

    Each round flips interior edges of the flipped triangles where both new
    triangles are positive in both meshes, then moves the free vertices of the
    triangles still flipped (and of ``min(round − 1, 3)`` rings around them) to
    the Chebyshev centre of their one-ring's kernel.

    Parameters
    ----------
    Xs, Xt : (n, 2) float64
    F : (m, 3) int64
    fixed : (n,) bool
        Vertices that must not move.
    repair_rounds : int

    Returns
    -------
    Xs, Xt : (n, 2) float64
    F : (m, 3) int64
    rounds : int
        Rounds that found something flipped.
    """
    n = Xs.shape[0]
    rounds = 0
    for rounds in range(1, repair_rounds + 1):
        bad_s = np.flatnonzero(_areas(Xs, F) <= 0)
        bad_t = np.flatnonzero(_areas(Xt, F) <= 0)
        if bad_s.size == 0 and bad_t.size == 0:
            rounds -= 1
            break
        F, _ = _edge_flips(Xs, Xt, F, np.union1d(bad_s, bad_t))
        vf = _vertex_faces(F, n)
        for X_idx in (0, 1):
            X = Xs if X_idx == 0 else Xt
            badx = np.flatnonzero(_areas(X, F) <= 0)
            if badx.size:
                verts = {int(v) for v in F[badx].ravel()}
                for _ in range(min(rounds - 1, 3)):
                    verts |= {int(w) for v in verts for f in vf[v] for w in F[f]}
                X = _relocate(X, F, vf, verts, fixed)
                if X_idx == 0:
                    Xs = X
                else:
                    Xt = X
    return Xs, Xt, F, rounds
