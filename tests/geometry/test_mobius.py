import numpy as np
import pytest

from conformorph.geometry.boundary_loop import boundary_loop
from conformorph.geometry.mobius import mobius_disk, normalize_disk_map
from tests.meshes import disk_grid


def test_mobius_by_hand():
    a = 0.5 + 0.0j
    # z -> (z - a) / (1 - conj(a) z): 0 -> -a, a -> 0, 1 -> 1, -1 -> -1
    w = mobius_disk(np.array([0.0, 0.5, 1.0, -1.0], dtype=complex), a)
    np.testing.assert_allclose(w, [-0.5, 0, 1, -1], atol=1e-15)
    w = mobius_disk(np.array([0.0j]), 0.3j, theta=np.pi / 2)
    np.testing.assert_allclose(w, [1j * -0.3j], atol=1e-15)


def test_mobius_keeps_the_circle_and_the_disk_and_inverts():
    rng = np.random.default_rng(4)
    t = rng.uniform(0, 2 * np.pi, 100)
    z = np.exp(1j * t)
    inside = rng.uniform(0, 0.99, 100) * np.exp(1j * rng.uniform(0, 2 * np.pi, 100))
    a, th = 0.6 - 0.3j, 1.1
    np.testing.assert_allclose(np.abs(mobius_disk(z, a, th)), 1, atol=1e-14)
    assert np.all(np.abs(mobius_disk(inside, a, th)) < 1)
    # inverse: w -> e^{-i th} w, then the transform with -a
    back = mobius_disk(mobius_disk(inside, a, th) * np.exp(-1j * th), -a)
    np.testing.assert_allclose(back, inside, atol=1e-13)


def test_mobius_rejects_a_outside():
    with pytest.raises(ValueError):
        mobius_disk(np.zeros(2, dtype=complex), 1.0 + 0j)


def test_normalize_disk_map_sends_vertices_where_asked():
    V, F = disk_grid(5)
    b = boundary_loop(F)
    uv0 = V[:, :2].copy()
    c = int(np.argsort(np.hypot(*uv0.T))[7])  # some interior vertex off the centre
    av = int(b[3])
    uv = normalize_disk_map(uv0, b, c, av)
    np.testing.assert_allclose(uv[c], 0, atol=1e-15)
    assert abs(np.arctan2(uv[av, 1], uv[av, 0])) < 1e-15 and uv[av, 0] > 0
    np.testing.assert_allclose(np.hypot(*uv[b].T), 1, atol=1e-15)
    np.testing.assert_array_equal(uv0, V[:, :2])  # input untouched
    # normalising again with the same vertices changes nothing
    np.testing.assert_allclose(normalize_disk_map(uv, b, c, av), uv, atol=1e-14)


def test_normalize_disk_map_bad_vertices():
    V, F = disk_grid(3)
    b = boundary_loop(F)
    with pytest.raises(ValueError):
        normalize_disk_map(V[:, :2], b, center_vertex=int(b[0]))
    with pytest.raises(ValueError):
        normalize_disk_map(V[:, :2], b, angle_vertex=0)
    with pytest.raises(ValueError):
        normalize_disk_map(V[:, :2], b, center_vertex=V.shape[0])
