import numpy as np
import pytest

from conformorph import geometry as g


def test_signed_areas_and_flips_by_hand():
    uv = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1]])
    F = np.array([[0, 1, 2], [1, 2, 3], [1, 3, 2]])
    np.testing.assert_allclose(g.signed_areas_2d(uv, F), [0.5, -0.5, 0.5])
    assert g.flipped_triangles(uv, F).tolist() == [False, True, False]
    # a degenerate triangle counts as flipped
    assert g.flipped_triangles(np.array([[0.0, 0], [1, 0], [2, 0]]), np.array([[0, 1, 2]]))[0]


def test_max_orientation_step_by_hand():
    U = np.eye(2)[None]
    # det(I + s D) = (1 - s)(1 - 2 s): first root at s = 1/2
    D = np.array([[[-1.0, 0], [0, -2.0]]])
    assert g.max_orientation_step(U, D) == pytest.approx(0.5)
    # a rotation-like change never collapses det = 1 + s^2
    assert g.max_orientation_step(U, np.array([[[0.0, -1], [1, 0]]])) == np.inf
    # linear case (det D = 0): det = 1 - 3 s
    assert g.max_orientation_step(U, np.array([[[-3.0, 0], [0, 0]]])) == pytest.approx(1 / 3)


def test_max_orientation_step_is_the_first_collapse_over_many_triangles():
    rng = np.random.default_rng(4)
    U = rng.normal(size=(200, 2, 2))
    U[np.linalg.det(U) < 0, :, 0] *= -1
    D = rng.normal(size=(200, 2, 2))
    a = g.max_orientation_step(U, D)
    s = np.linspace(0, min(a, 50.0), 2001)[:-1]
    dets = np.linalg.det(U[None] + s[:, None, None, None] * D[None])
    assert dets.min() > 0
    if np.isfinite(a):
        assert np.linalg.det(U + a * D).min() == pytest.approx(0.0, abs=1e-9)
