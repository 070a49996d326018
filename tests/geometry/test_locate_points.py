"""Tests of geometry.locate_points."""

import numpy as np

from geometry.locate_points import locate_points

V = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
F = np.array([[0, 1, 2], [0, 2, 3]])


def test_hand_worked():
    face, bary = locate_points(V, F, np.array([[0.75, 0.25], [0.25, 0.75], [2.0, 0.0]]))
    assert face.tolist() == [0, 1, -1]
    assert np.allclose(bary[0], [0.25, 0.5, 0.25])
    assert np.all(np.isnan(bary[2]))


def test_reproduces_points_including_vertices_and_edges():
    rng = np.random.default_rng(0)
    P = np.vstack([rng.random((50, 2)), V, [[0.5, 0.5], [0.5, 0.0]]])
    face, bary = locate_points(V, F, P)
    assert np.all(face >= 0)
    assert np.allclose(np.einsum("kj,kjd->kd", bary, V[F[face]]), P)
    assert np.all(bary >= -1e-12)


def test_scale_invariance_and_no_mutation():
    P = np.array([[0.3, 0.1], [0.9, 0.95]])
    c = V.copy(), F.copy(), P.copy()
    f1, b1 = locate_points(V, F, P)
    f2, b2 = locate_points(1e-8 * V, F, 1e-8 * P)
    assert np.array_equal(f1, f2) and np.allclose(b1, b2)
    assert np.array_equal(V, c[0]) and np.array_equal(F, c[1]) and np.array_equal(P, c[2])
