"""sampled_surface_l2: the L2 of surface_to_surface_error, exact on small meshes, within
its stated bound on samples, reproducible."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.geometry import sampled_surface_l2, surface_to_surface_error
from tests.fixtures.make_service_small_face import small_face


def _pair() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    V, F = small_face(rings=25)  # 1,951 vertices
    W = V.copy()
    W[:, 2] += 2.0 * np.sin(V[:, 0] / 20.0) * np.cos(V[:, 1] / 25.0)
    return V, F, W


def test_small_meshes_are_measured_whole() -> None:
    V, F, W = _pair()
    got = sampled_surface_l2(W, F, V, F, samples=5000)
    exact = surface_to_surface_error(W, F, V, F)
    assert got["L2_bound"] == 0.0
    for k in ("L2", "L2_forward", "L2_backward"):
        assert got[k] == exact[k]


def test_a_sample_lands_within_its_bound_and_the_bound_shrinks() -> None:
    V, F, W = _pair()
    exact = surface_to_surface_error(W, F, V, F)["L2"]
    bounds = []
    for samples in (200, 800):
        for seed in range(5):
            got = sampled_surface_l2(W, F, V, F, samples=samples, seed=seed)
            assert 0 < got["L2_bound"] < 0.5 * exact
            assert abs(got["L2"] - exact) <= got["L2_bound"], (samples, seed)
        bounds.append(got["L2_bound"])
    # four times the samples: about half the bound (1 / sqrt(samples))
    assert 0.3 < bounds[1] / bounds[0] < 0.7
    again = sampled_surface_l2(W, F, V, F, samples=800, seed=4)
    assert again == got  # the same seed, the same figures


def test_identical_surfaces_and_checks() -> None:
    V, F, _ = _pair()
    assert sampled_surface_l2(V, F, V, F, samples=100)["L2"] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="samples"):
        sampled_surface_l2(V, F, V, F, samples=1)
    with pytest.raises(ValueError, match="zero extent"):
        sampled_surface_l2(V, F, np.zeros_like(V), F)
