"""Mean-value Laplacian (Floater 2003)."""

import numpy as np

from conformorph import geometry as g
from tests.meshes import disk_grid


def test_regular_fan_by_hand():
    # centre of a regular hexagon of radius 1: both corner angles at the centre are π/3,
    # so every spoke weight is 2 tan(π/6) / 1
    t = np.arange(6) * np.pi / 3
    V = np.vstack([[0, 0], np.column_stack([np.cos(t), np.sin(t)])])
    F = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)])
    W = g.mean_value_laplacian(V, F).toarray()
    np.testing.assert_allclose(W[0, 1:], -2 * np.tan(np.pi / 6), rtol=1e-14)
    assert W[0, 0] == np.float64(-W[0, 1:].sum())


def test_rows_sum_to_zero_weights_positive_and_linear_precision():
    rng = np.random.default_rng(0)
    V, F = disk_grid(5)
    P = V[:, :2].copy()
    interior = np.setdiff1d(np.arange(len(P)), g.boundary_loop(F))
    P[interior] += rng.uniform(-0.03, 0.03, size=(interior.size, 2))  # irregular, still embedded
    W = g.mean_value_laplacian(P, F)
    np.testing.assert_allclose(W.sum(axis=1), 0, atol=1e-12)
    off = W.copy()
    off.setdiag(0)
    assert off.min() < 0 and off.max() <= 0
    # linear precision: every interior vertex is the weighted mean of its neighbours
    np.testing.assert_allclose((W @ P)[interior], 0, atol=1e-12)


def test_scale_and_translation():
    V, F = disk_grid(3)
    W = g.mean_value_laplacian(V[:, :2], F).toarray()
    W2 = g.mean_value_laplacian(3 * V[:, :2] + 7.0, F).toarray()
    np.testing.assert_allclose(W2, W / 3, rtol=1e-12)
