"""Tests of conformorph.geometry.strain_targets (ε^t of eq. 2 / eq. 3 and the area ratio it prescribes)."""

import numpy as np
import pytest

from conformorph.geometry.strain_targets import prescribed_area_ratio, strain_target


@pytest.mark.parametrize("scheme", ["modified", "linear", "principal"])
def test_uniform_scaling_by_hand(scheme):
    # scaling by s: E = (s² − 1)/2 I, det(I + 2E) = s⁴, so the area ratio is s²
    s = 2.0
    eps_n = np.array([[(s * s - 1) / 2, (s * s - 1) / 2, 0.0]])
    eps_1, d_1 = strain_target(eps_n, 1.0, scheme)
    np.testing.assert_allclose(eps_1, eps_n, atol=1e-12)
    np.testing.assert_allclose(d_1, [s * s])
    eps_0, d_0 = strain_target(eps_n, 0.0, scheme)
    np.testing.assert_allclose(eps_0, 0.0, atol=1e-15)
    np.testing.assert_allclose(d_0, [1.0])


def test_linear_scheme_is_eq_2():
    eps_n = np.array([[0.3, -0.1, 0.2], [1.0, 0.5, -0.4]])
    eps_t, d = strain_target(eps_n, 0.25, "linear")
    np.testing.assert_allclose(eps_t, 0.25 * eps_n)
    np.testing.assert_allclose(d, prescribed_area_ratio(0.25 * eps_n))


def test_modified_scheme_stretches_linearly_in_t():
    # eq. (3): an x-stretch by λ gives length 1 + t(λ − 1) at time t
    lam = 3.0
    eps_n = np.array([[(lam * lam - 1) / 2, 0.0, 0.0]])
    eps_t, d = strain_target(eps_n, 0.5, "modified")
    stretch = 1 + 0.5 * (lam - 1)
    np.testing.assert_allclose(eps_t, [[(stretch**2 - 1) / 2, 0.0, 0.0]])
    np.testing.assert_allclose(d, [stretch])


def test_unrealisable_strain_gets_the_floor():
    assert prescribed_area_ratio(np.array([[-0.5, -0.5, 0.0]]))[0] == pytest.approx(1e-3)
