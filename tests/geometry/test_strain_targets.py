"""Tests of conformorph.geometry.strain_targets (ε^t of eq. 2 / eq. 3 and the area ratio it prescribes)."""

import numpy as np
import pytest

from conformorph.geometry.strain_targets import prescribed_area_ratio, strain_target
from conformorph.geometry.tolerances import STRAIN_AREA_SLACK


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


def _principal_stretches(eps: np.ndarray) -> np.ndarray:
    """Principal stretches sqrt(eig(I + 2E)) per triangle, ascending."""
    C = np.stack(
        [
            np.stack([1 + 2 * eps[:, 0], eps[:, 2]], axis=1),
            np.stack([eps[:, 2], 1 + 2 * eps[:, 1]], axis=1),
        ],
        axis=1,
    )
    return np.sqrt(np.linalg.eigvalsh(C))


@pytest.mark.parametrize("scheme", ["modified", "principal"])
def test_rest_areas_keep_the_total_area_between_the_end_frames(scheme):
    # stretch by 3 along x, squash by 1/3 along y: area kept at both ends, but eq. (3)
    # makes the stretches 1 + 2t and 1 − 2t/3, an area of 4/3 at t = 1/2 (by hand)
    eps_n = np.array([[4.0, -4.0 / 9.0, 0.0], [4.0, -4.0 / 9.0, 0.0]])
    areas = np.array([1.0, 2.0])
    free, d_free = strain_target(eps_n, 0.5, scheme)
    np.testing.assert_allclose(d_free, [4.0 / 3.0] * 2)
    eps_t, d_t = strain_target(eps_n, 0.5, scheme, areas)
    bound = 1.0 + STRAIN_AREA_SLACK  # both ends have the source's area
    assert areas @ d_t / areas.sum() == pytest.approx(bound)
    np.testing.assert_allclose(d_t, prescribed_area_ratio(eps_t))
    # a uniform dilation: each triangle keeps the shape eq. (3) gives it
    lam_free, lam = _principal_stretches(free), _principal_stretches(eps_t)
    np.testing.assert_allclose(lam[:, 1] / lam[:, 0], lam_free[:, 1] / lam_free[:, 0])
    # the end frames are eq. (3)'s
    np.testing.assert_array_equal(strain_target(eps_n, 1.0, scheme, areas)[0], eps_n)
    np.testing.assert_array_equal(strain_target(eps_n, 0.0, scheme, areas)[0], 0.0)


def test_rest_areas_leave_a_total_inside_the_end_frames_unchanged():
    # uniform scaling by 2: eq. (3) gives area (1 + t)², between 1 and 4 throughout
    eps_n = np.array([[1.5, 1.5, 0.0], [0.0, 0.0, 0.0]])
    for t in (0.1, 0.5, 0.9):
        bounded = strain_target(eps_n, t, "modified", np.array([1.0, 1.0]))
        plain = strain_target(eps_n, t, "modified")
        np.testing.assert_array_equal(bounded[0], plain[0])
        np.testing.assert_array_equal(bounded[1], plain[1])


def test_area_gain_bounds_the_area_a_frame_is_expected_to_get():
    # uniform scaling by 2, eq. (3): area (1 + t)² = 2.25 at t = 1/2, inside [1, 4]; a
    # frame expected to get twice its prescribed area (4.5) is dilated to the bound
    eps_n = np.array([[1.5, 1.5, 0.0]])
    a = np.array([1.0])
    plain = strain_target(eps_n, 0.5, "modified", a)
    np.testing.assert_allclose(plain[1], [2.25])
    eps_t, d_t = strain_target(eps_n, 0.5, "modified", a, area_gain=2.0)
    np.testing.assert_allclose(2.0 * d_t, [4.0 * (1.0 + STRAIN_AREA_SLACK)])
    np.testing.assert_allclose(d_t, prescribed_area_ratio(eps_t))
