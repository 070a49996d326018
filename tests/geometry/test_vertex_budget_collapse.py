"""Tests of conformorph.geometry.vertex_budget_collapse (vertex budget by collapses valid in both meshes)."""

import numpy as np
import pytest
from scipy.spatial import Delaunay

from conformorph.geometry.compatible_mesh_quality import min_triangle_angle
from conformorph.geometry.compatible_triangulation import compatible_triangulation
from conformorph.geometry.flip_repair import _areas
from conformorph.geometry.vertex_budget_collapse import (
    budgeted_triangulation,
    collapse_to_vertex_budget,
)

from .test_compatible_triangulation import check, load_pair


def _grid_pair(k=7, seed=0):
    """A jittered k×k grid on the unit square (Delaunay), and an affine image of it with
    a smooth bend; the square's boundary vertices fixed."""
    rng = np.random.default_rng(seed)
    g = np.linspace(0.0, 1.0, k)
    P = np.array([[x, y] for y in g for x in g])
    inner = (P > 0).all(axis=1) & (P < 1).all(axis=1)
    P[inner] += rng.uniform(-0.25, 0.25, size=(int(inner.sum()), 2)) / (k - 1)
    F = Delaunay(P).simplices.astype(np.int64)
    F[_areas(P, F) < 0] = F[_areas(P, F) < 0][:, [0, 2, 1]]
    Q = P @ np.array([[1.5, 0.3], [0.0, 0.8]]) + 0.05 * np.sin(3.0 * P[:, ::-1])
    return P, Q, F, ~inner


def test_hand_worked_square_fan():
    # a 2×2 square fanned around its centre: all angles 45°; a budget of 4 collapses the
    # centre onto a corner, leaving the square cut by a diagonal (two 45° triangles)
    V = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2], [1, 1]])
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    fixed = np.array([True, True, True, True, False])
    Xs, Xt, F2, fx, ids, k = collapse_to_vertex_budget(V, 2.0 * V, F, fixed, 4)
    assert k == 1 and ids.tolist() == [0, 1, 2, 3] and fx.all()
    assert F2.shape == (2, 3)
    assert _areas(Xs, F2).sum() == pytest.approx(4.0)
    assert min_triangle_angle(Xs, F2) == pytest.approx(45.0)
    # a budget already met changes nothing
    Xs, Xt, F3, fx, ids, k = collapse_to_vertex_budget(V, 2.0 * V, F, fixed, 5)
    assert k == 0 and np.array_equal(F3, F) and ids.tolist() == [0, 1, 2, 3, 4]


def test_fixed_vertices_are_never_collapsed():
    V = np.array([[0.0, 0], [2, 0], [2, 2], [0, 2], [1, 1]])
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    out = collapse_to_vertex_budget(V, V, F, np.ones(5, dtype=bool), 3)
    assert out[5] == 0 and np.array_equal(out[2], F)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("budget", [40, 30, 3])
def test_invariants_on_a_bent_grid(seed, budget):
    P, Q, F, fixed = _grid_pair(seed=seed)
    before = min(min_triangle_angle(P, F), min_triangle_angle(Q, F))
    Xs, Xt, F2, fx, ids, k = collapse_to_vertex_budget(P, Q, F, fixed, budget)
    n = Xs.shape[0]
    assert n == P.shape[0] - k
    assert n <= max(budget, int(fixed.sum())) or k < int((~fixed).sum())  # or refused
    if budget >= 40:
        assert n == budget  # easily reachable: met exactly, never overshot
    assert np.all(_areas(Xs, F2) > 0) and np.all(_areas(Xt, F2) > 0)
    np.testing.assert_array_equal(Xs, P[ids])
    np.testing.assert_array_equal(Xt, Q[ids])
    assert fx.sum() == fixed.sum() and np.all(fixed[ids] == fx)
    # the area is covered exactly once, and every vertex is used
    assert _areas(Xs, F2).sum() == pytest.approx(_areas(P, F).sum())
    assert _areas(Xt, F2).sum() == pytest.approx(_areas(Q, F).sum())
    assert np.array_equal(np.unique(F2), np.arange(n))
    # no minimum angle falls below min(last bound 20° / 2**3, what it was)
    after = min(min_triangle_angle(Xs, F2), min_triangle_angle(Xt, F2))
    assert after >= min(20.0 / 8, before) - 1e-9


def test_the_first_bound_is_kept_when_it_meets_the_budget():
    P, Q, F, fixed = _grid_pair(seed=5)
    before = min(min_triangle_angle(P, F), min_triangle_angle(Q, F))
    Xs, Xt, F2, *_ = collapse_to_vertex_budget(P, Q, F, fixed, 46)  # 3 collapses
    after = min(min_triangle_angle(Xs, F2), min_triangle_angle(Xt, F2))
    assert Xs.shape[0] == 46 and after >= min(20.0, before) - 1e-9


def test_budgeted_triangulation_of_the_annulus_pair():
    S, T, anchors = load_pair("annulus_round", "annulus_square")
    ct = compatible_triangulation(S, T, anchors)
    n = ct.source_V.shape[0]
    assert budgeted_triangulation(ct, n) is ct  # within the budget: unchanged
    small = budgeted_triangulation(ct, n - 30)
    assert small.source_V.shape[0] == n - 30 and small.budget_collapses == 30
    check(small, S, T, anchors)  # boundary, corners, anchors kept; no flips; areas
    assert small.min_angle[0] >= min(2.5, ct.min_angle[0]) - 1e-9
    with pytest.raises(ValueError, match="max_vertices"):
        budgeted_triangulation(ct, 2)


def test_invariant_to_scale_and_translation():
    P, Q, F, fixed = _grid_pair(seed=3)
    ref = collapse_to_vertex_budget(P, Q, F, fixed, 35)
    for s in (1e-8, 1e8):
        out = collapse_to_vertex_budget(s * P + 3.0, s * Q - 1.0, F, fixed, 35)
        np.testing.assert_array_equal(out[4], ref[4])
        np.testing.assert_array_equal(out[2], ref[2])


def test_inputs_not_mutated():
    P, Q, F, fixed = _grid_pair(seed=4)
    copies = [a.copy() for a in (P, Q, F, fixed)]
    collapse_to_vertex_budget(P, Q, F, fixed, 30)
    for a, c in zip((P, Q, F, fixed), copies, strict=True):
        np.testing.assert_array_equal(a, c)


def test_errors():
    P, Q, F, fixed = _grid_pair()
    with pytest.raises(ValueError, match="max_vertices"):
        collapse_to_vertex_budget(P, Q, F, fixed, 2)
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        collapse_to_vertex_budget(P, Q[:-1], F, fixed, 30)
    with pytest.raises(ValueError, match=r"\(m, 3\)"):
        collapse_to_vertex_budget(P, Q, F[:, :2], fixed, 30)
    with pytest.raises(ValueError, match="positive"):
        collapse_to_vertex_budget(P, Q, F[:, [0, 2, 1]], fixed, 30)
