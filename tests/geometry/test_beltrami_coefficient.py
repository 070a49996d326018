import numpy as np
import pytest

from conformorph.geometry.beltrami_coefficient import beltrami_coefficient, triangle_frames
from conformorph.geometry.stereographic_projection import stereographic_projection
from tests.meshes import bumpy_disk, random_rotation, spherical_cap

TRI_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
TRI_F = np.array([[0, 1, 2]])


@pytest.mark.parametrize("a", [0.5, 2.0, 3.0])
def test_axis_stretch_by_hand(a):
    # uv = (a x, y): the surface -> disk map has |mu| = |a - 1| / (a + 1)
    uv = TRI_V[:, :2] * [a, 1.0]
    mu = beltrami_coefficient(TRI_V, TRI_F, uv)
    np.testing.assert_allclose(np.abs(mu), abs(a - 1) / (a + 1), rtol=1e-12)
    # the disk -> surface map x = u / a stretches along u: mu is real, sign (1/a - 1)
    np.testing.assert_allclose(mu, (1 / a - 1) / (1 / a + 1), atol=1e-12)


def test_similarity_is_zero_and_flip_is_above_one():
    ang = 0.7
    Rz = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    uv = 2.5 * TRI_V[:, :2] @ Rz.T + [3, -1]
    assert abs(beltrami_coefficient(TRI_V, TRI_F, uv)[0]) < 1e-14
    flipped = uv * [1, -1]
    assert abs(beltrami_coefficient(TRI_V, TRI_F, flipped)[0]) > 1e6  # reflection: g_z = 0
    sheared = TRI_V[:, :2] @ np.array([[1.0, 0.3], [0.0, 1.0]]).T
    mu = beltrami_coefficient(TRI_V, TRI_F, sheared * [1, -1])
    assert abs(mu[0]) > 1


def test_frames_are_isometric_and_ccw():
    V, F = bumpy_disk(4)
    X = triangle_frames(V, F)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        np.testing.assert_allclose(
            np.linalg.norm(X[:, i] - X[:, j], axis=1),
            np.linalg.norm(V[F[:, i]] - V[F[:, j]], axis=1),
        )
    assert np.all(X[:, 2, 1] > 0)


def test_conformal_map_of_a_cap_has_small_mu_converging():
    # stereographic projection is conformal: |mu| -> 0 under refinement (O(h))
    means = []
    for k in (4, 8, 16):
        V, F = spherical_cap(k)
        mu = np.abs(beltrami_coefficient(V, F, stereographic_projection(V)))
        means.append(mu.max())
    assert means[-1] < 0.02
    assert means[0] / means[1] > 1.8 and means[1] / means[2] > 1.8


def test_invariance_rigid_scale_and_input_untouched():
    V, F = bumpy_disk(5)
    uv = V[:, :2] + 0.1 * V[:, 2:3]
    V0, uv0 = V.copy(), uv.copy()
    mu = beltrami_coefficient(V, F, uv)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(uv, uv0)
    for s in (1e-3, 1e3):
        R = random_rotation(2)
        np.testing.assert_allclose(beltrami_coefficient(s * V @ R.T + 7, F, uv), mu, atol=1e-10)
        # scaling or rotating the disk leaves |mu| and (for a scale) mu unchanged
        np.testing.assert_allclose(beltrami_coefficient(V, F, s * uv), mu, atol=1e-10)
    perm = np.random.default_rng(0).permutation(F.shape[0])
    np.testing.assert_allclose(beltrami_coefficient(V, F[perm], uv), mu[perm])
    # rotating each triangle's corners does not change its mu
    np.testing.assert_allclose(beltrami_coefficient(V, np.roll(F, 1, axis=1), uv), mu, atol=1e-12)


def test_bad_shapes_raise():
    with pytest.raises(ValueError):
        beltrami_coefficient(TRI_V, TRI_F, TRI_V)
    with pytest.raises(ValueError):
        beltrami_coefficient(TRI_V[:, :2], TRI_F, TRI_V[:, :2])
