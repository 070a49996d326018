"""biharmonic_fill and uniform_laplacian."""

import numpy as np
import pytest

from conformorph.geometry import biharmonic_fill, uniform_laplacian
from conformorph.geometry.mesh_errors import SingularSystemError
from tests.meshes import disk_grid, spherical_cap


def test_uniform_laplacian_hand_case() -> None:
    L = uniform_laplacian(np.array([[0, 1, 2], [0, 2, 3]]), 4).toarray()
    expected = np.array(
        [[3, -1, -1, -1], [-1, 2, -1, 0], [-1, -1, 3, -1], [-1, 0, -1, 2]], dtype=float
    )
    np.testing.assert_array_equal(L, expected)
    np.testing.assert_allclose(L @ np.ones(4), 0)


def test_square_centre_hand_case() -> None:
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    P = np.array([[0.0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1], [9, 9, 9]])
    out = biharmonic_fill(F, P, np.array([4]))
    np.testing.assert_allclose(out[4], [0.5, 0.5, 1.0])
    np.testing.assert_array_equal(out[:4], P[:4])
    assert P[4, 0] == 9  # input not mutated


def test_constant_and_linear_fields_reproduced_on_regular_grid() -> None:
    # interior of a regular triangular lattice: the uniform Laplacian of a linear
    # function vanishes there, so a linear field is filled exactly
    ij = np.array([(i, j) for j in range(9) for i in range(9)], dtype=float)
    P = ij[:, 0:1] * np.array([1.0, 0]) + ij[:, 1:2] * np.array([0.5, np.sqrt(3) / 2])
    idx = np.arange(81).reshape(9, 9)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    F = np.vstack([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([b, d, c], -1).reshape(-1, 3)])
    values = np.column_stack([np.ones(81), 2 * P[:, 0] - 3 * P[:, 1] + 1])
    unknown = idx[3:6, 3:6].ravel()
    guess = values.copy()
    guess[unknown] = 0
    np.testing.assert_allclose(biharmonic_fill(F, guess, unknown), values, atol=1e-10)


def test_cap_fill_is_close_to_the_sphere() -> None:
    V, F = spherical_cap(10, 0.6)
    r = np.linalg.norm(V[:, :2], axis=1)
    unknown = np.flatnonzero(r < 0.3)
    W = V.copy()
    W[unknown] = 0
    out = biharmonic_fill(F, W, unknown)
    err = np.abs(np.linalg.norm(out[unknown], axis=1) - 1).max()
    assert err < 0.01  # a curved fill, not the flat chord (which is 0.03 below)
    flat_gap = 1 - np.cos(np.arcsin(0.3 * 0.8))
    assert err < 0.3 * flat_gap


def test_failures() -> None:
    V, F = disk_grid(2)
    with pytest.raises(ValueError, match="repeats"):
        biharmonic_fill(F, V, np.array([1, 1]))
    with pytest.raises(ValueError):
        biharmonic_fill(F, V[:, 0], np.array([1]))
    with pytest.raises(ValueError, match="finite"):
        W = V.copy()
        W[2] = np.nan
        biharmonic_fill(F, W, np.array([1]))
    with pytest.raises(ValueError, match="every vertex"):
        biharmonic_fill(F, V, np.arange(V.shape[0]))
    # an unknown piece not connected to any known vertex: singular, never NaN
    F2 = np.vstack([F, [[V.shape[0], V.shape[0] + 1, V.shape[0] + 2]]])
    W = np.vstack([V, np.zeros((3, 3))])
    with pytest.raises(SingularSystemError):
        biharmonic_fill(F2, W, np.arange(V.shape[0], V.shape[0] + 3))
