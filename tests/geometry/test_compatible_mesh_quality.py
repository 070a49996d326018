"""Tests of conformorph.geometry.compatible_mesh_quality (minimum angles, sliver collapse, quality flips)."""

import numpy as np
import pytest

from conformorph.geometry.compatible_mesh_quality import (
    _collapse_choice,
    _corner_min_angles,
    _flip_candidates,
    collapse_slivers,
    improve_quality,
    min_triangle_angle,
)
from conformorph.geometry.flip_repair import _areas

V = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.3, 0.2]])
F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
FIXED = np.array([True, True, True, True, False])


def test_min_triangle_angle_by_hand():
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    assert min_triangle_angle(tri, np.array([[0, 1, 2]])) == pytest.approx(45.0)


def test_improve_quality_raises_the_minimum_angle_and_keeps_orientation():
    Xs, Xt = V.copy(), 2.0 * V
    before = min(min_triangle_angle(Xs, F), min_triangle_angle(Xt, F))
    F2 = improve_quality(Xs, Xt, F, FIXED, 3)
    after = min(min_triangle_angle(Xs, F2), min_triangle_angle(Xt, F2))
    assert after > before
    assert np.all(_areas(Xs, F2) > 0) and np.all(_areas(Xt, F2) > 0)
    np.testing.assert_array_equal(Xs[:4], V[:4])  # fixed vertices stay


def test_collapse_slivers_drops_a_vertex_and_reports_the_kept_ids():
    # a free vertex almost on the diagonal's end: collapsing it onto a corner helps
    W = V.copy()
    W[4] = [0.05, 0.04]
    Xs, Xt, F2, fixed, ids, collapsed = collapse_slivers(W, 2.0 * W, F, FIXED)
    assert collapsed == 1 and ids.tolist() == [0, 1, 2, 3]
    assert F2.shape[0] == 2 and fixed.all()
    assert np.all(_areas(Xs, F2) > 0) and np.all(_areas(Xt, F2) > 0)


def _reference_quality_flips(Xs, Xt, F, passes):
    """The edge-by-edge loop that _quality_flips replaced (angles of each pair computed apart)."""

    def pair_min(X, tris):
        return min_triangle_angle(X, tris) if _areas(X, tris).min() > 0 else -1.0

    F = F.copy()
    total = 0
    for _ in range(passes):
        edge_faces = {}
        for f, tri in enumerate(F):
            for k in range(3):
                i, j = int(tri[k]), int(tri[(k + 1) % 3])
                edge_faces.setdefault((min(i, j), max(i, j)), []).append(f)
        touched, done = set(), 0
        for (i, j), fs in edge_faces.items():
            if len(fs) != 2 or fs[0] in touched or fs[1] in touched:
                continue
            f, g = fs
            tf = F[f]
            k = int(np.flatnonzero((tf != i) & (tf != j))[0])
            p, a, b = int(tf[k]), int(tf[(k + 1) % 3]), int(tf[(k + 2) % 3])
            q = int([x for x in F[g] if x != a and x != b][0])
            old, new = np.array([F[f], F[g]]), np.array([[p, a, q], [p, q, b]])
            before = min(pair_min(Xs, old), pair_min(Xt, old))
            after = min(pair_min(Xs, new), pair_min(Xt, new))
            if after > before + 1e-9:
                F[f], F[g] = new
                touched.update((f, g))
                done += 1
        total += done
        if done == 0:
            break
    return F, total


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_quality_flips_match_the_edge_by_edge_loop(seed):
    from scipy.spatial import Delaunay

    from conformorph.geometry.compatible_mesh_quality import _quality_flips

    rng = np.random.default_rng(seed)
    Xs = rng.random((80, 2))
    F0 = Delaunay(Xs).simplices.astype(np.int64)
    F0 = np.where((_areas(Xs, F0) > 0)[:, None], F0, F0[:, [0, 2, 1]])
    # a shear and a small random move: poor angles in the target, some flips wanted
    Xt = Xs @ np.array([[1.0, 0.0], [1.6, 0.4]]) + 0.002 * rng.standard_normal(Xs.shape)
    got, n_got = _quality_flips(Xs, Xt, F0, passes=3)
    want, n_want = _reference_quality_flips(Xs, Xt, F0, passes=3)
    assert n_got == n_want > 0
    np.testing.assert_array_equal(got, want)
    worse = min(min_triangle_angle(Xs, F0), min_triangle_angle(Xt, F0))
    assert min(min_triangle_angle(Xs, got), min_triangle_angle(Xt, got)) >= worse


def test_quality_flips_without_interior_edges_change_nothing():
    from conformorph.geometry.compatible_mesh_quality import _quality_flips

    tri = np.array([[0, 1, 2]])
    got, n = _quality_flips(V[:3], V[:3], tri, passes=2)
    assert n == 0
    np.testing.assert_array_equal(got, tri)


def test_corner_min_angles_by_hand_and_against_arccos():
    P = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, np.sqrt(3) / 2], [2.0, 0.0]])
    T = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 1], [0, 1, 4]])  # right, equilateral, cw, flat
    np.testing.assert_allclose(_corner_min_angles(P, T), [45.0, 60.0, 45.0, 0.0], atol=1e-12)
    rng = np.random.default_rng(5)
    Q = rng.normal(size=(40, 2))
    tris = np.array([t for t in rng.integers(0, 40, (200, 3)) if len(set(t)) == 3])
    want = np.full(len(tris), 180.0)
    for k in range(3):
        a = Q[tris[:, (k + 1) % 3]] - Q[tris[:, k]]
        b = Q[tris[:, (k + 2) % 3]] - Q[tris[:, k]]
        cos = (a * b).sum(1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        want = np.minimum(want, np.degrees(np.arccos(np.clip(cos, -1, 1))))
    np.testing.assert_allclose(_corner_min_angles(Q, tris), want, atol=1e-6)


def test_corner_min_angles_bitwise_the_three_corner_formula():
    """One arccos of the largest cosine is, to the bit, the smallest of the three
    corners' arccos (each corner's cosine from its own two edges, clipped), degenerate
    triangles (0) included."""
    rng = np.random.default_rng(11)
    Q = np.vstack([rng.normal(size=(60, 2)), [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]])
    tris = np.vstack([rng.integers(0, 60, (500, 3)), [[60, 61, 62], [60, 60, 61]]])
    P = Q[tris]
    a = P[:, [1, 2, 0]] - P
    b = P[:, [2, 0, 1]] - P
    dot = a[:, :, 0] * b[:, :, 0] + a[:, :, 1] * b[:, :, 1]
    na = np.sqrt(a[:, :, 0] * a[:, :, 0] + a[:, :, 1] * a[:, :, 1])
    nb = np.sqrt(b[:, :, 0] * b[:, :, 0] + b[:, :, 1] * b[:, :, 1])
    cos = dot / np.maximum(na * nb, 1e-300)
    want = np.degrees(np.arccos(np.clip(cos, -1, 1))).min(axis=1, initial=180.0)
    np.testing.assert_array_equal(_corner_min_angles(Q, tris), want)
    assert _corner_min_angles(Q, np.zeros((0, 3), dtype=np.int64)).shape == (0,)


def test_collapse_choice_is_the_brute_force_best_neighbour():
    W = V.copy()
    W[4] = [0.05, 0.04]  # near corner 0: collapsing onto 0 leaves the two good halves
    vf = [set() for _ in range(5)]
    for f, tri in enumerate(F):
        for w in tri:
            vf[int(w)].add(f)
    worst = min_triangle_angle(W, F)
    u = _collapse_choice(W, 2.0 * W, F, vf, [0, 1, 2, 3], 4, worst)[0]
    best, arg = worst, -1
    for c in range(4):  # every neighbour passes the link condition in this fan
        rows = np.array([t for t in F if c not in t])
        rows[rows == 4] = c
        if _areas(W, rows).min() > 0 and _areas(2.0 * W, rows).min() > 0:
            a = min_triangle_angle(W, rows)
            if a > best + 1e-9:
                best, arg = a, c
    assert u == arg == 0
    # nothing above the current worst angle: no collapse
    assert _collapse_choice(W, 2.0 * W, F, vf, [0, 1, 2, 3], 4, 90.0)[0] == -1


def test_flip_candidates_by_hand_and_in_first_appearance_order():
    # the square's four fan triangles around vertex 4: interior edges 0-4, 1-4, 2-4, 3-4
    fg, new, old = _flip_candidates(F)
    # edge 1-4 appears first (face 0, corner 1), then 4-0 (face 0, corner 2), 2-4, 3-4
    assert fg.tolist() == [[0, 1], [0, 3], [1, 2], [2, 3]]
    # edge 1→4 in face 0 = [0, 1, 4]: p = 0 opposite it, q = 2 opposite it in face 1
    assert new[0].tolist() == [[0, 1, 2], [0, 2, 4]]
    np.testing.assert_array_equal(old, F[fg])
    # a fifth face on edges 0-4 and 4-2 gives each three faces: both are left out
    F5 = np.vstack([F, [[0, 4, 2]]])
    assert _flip_candidates(F5)[0].tolist() == [[0, 1], [2, 3]]
    assert _flip_candidates(np.zeros((0, 3), dtype=np.int64))[0].shape == (0, 2)
