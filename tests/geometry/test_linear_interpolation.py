"""Tests of conformorph.geometry.linear_interpolation."""

import numpy as np
import pytest

from conformorph.geometry.linear_interpolation import linear_interpolation


def test_hand_worked_and_end_points():
    S = np.array([[0.0, 0.0], [2.0, 0.0]])
    T = np.array([[2.0, 2.0], [0.0, 2.0]])
    frames = linear_interpolation(S, T, [0.0, 0.5, 1.0])
    assert frames.shape == (3, 2, 2)
    assert np.array_equal(frames[0], S) and np.array_equal(frames[2], T)
    assert np.allclose(frames[1], [[1, 1], [1, 1]])  # the classic collapse through a point


def test_shape_mismatch_and_no_mutation():
    S = np.zeros((3, 2))
    with pytest.raises(ValueError):
        linear_interpolation(S, np.zeros((4, 2)), [0.5])
    T = np.ones((3, 2))
    linear_interpolation(S, T, [0.5])
    assert np.all(S == 0) and np.all(T == 1)
