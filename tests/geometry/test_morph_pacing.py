import numpy as np
import pytest

from conformorph.geometry.morph_metrics_2d import morph_metrics_2d
from conformorph.geometry.morph_pacing import even_pace_times, path_steps


def test_hand_worked_quadratic_path():
    """x(t) = t²: equal lengths at t = √(k/(n−1))."""
    t = np.linspace(0.0, 1.0, 2001)
    path = (t**2)[:, None, None] * np.array([[[3.0, 4.0]]])  # |x'| ∝ t
    tau = even_pace_times(t, path, 5)
    np.testing.assert_allclose(tau, np.sqrt(np.linspace(0, 1, 5)), atol=1e-6)


def test_retimed_path_is_evenly_paced_and_converges_with_samples():
    V = np.array([[0.0, 0], [1, 0], [0, 1]])
    F = np.array([[0, 1, 2]])

    def path(t: np.ndarray) -> np.ndarray:  # a shear that snaps near t = 1, like eq. (3)
        g = np.tan(t * np.arctan(13.0))
        return np.stack([V + np.c_[g * V[:, 1], 0 * g * V[:, 1]] for g in g])

    uniform = np.linspace(0, 1, 61)
    assert morph_metrics_2d(V, F, path(uniform)).max_step_ratio > 5
    ratios = []
    for samples in (61, 241, 961):
        ts = np.linspace(0, 1, samples)
        tau = even_pace_times(ts, path(ts), 61)
        assert tau[0] == 0 and tau[-1] == 1 and np.all(np.diff(tau) >= 0)
        ratios.append(morph_metrics_2d(V, F, path(tau)).max_step_ratio)
    assert ratios[-1] < 1.01 and ratios[0] > ratios[1] > ratios[2]


def test_still_path_and_bad_input():
    V = np.zeros((3, 2))
    t = np.linspace(0, 1, 5)
    np.testing.assert_allclose(even_pace_times(t, np.stack([V] * 5), 3), [0, 0.5, 1])
    np.testing.assert_allclose(path_steps(np.stack([V, V + [3.0, 4.0]])), [5.0])
    with pytest.raises(ValueError, match="increasing"):
        even_pace_times([0.0, 0.0], np.stack([V] * 2), 3)
    with pytest.raises(ValueError, match="samples"):
        even_pace_times(t, np.stack([V] * 4), 3)
    with pytest.raises(ValueError, match="count"):
        even_pace_times(t, np.stack([V] * 5), 1)
