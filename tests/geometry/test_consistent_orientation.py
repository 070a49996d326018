"""consistent_orientation: faces flipped to agree, each component as its majority."""

import numpy as np
import pytest

from conformorph.geometry import consistent_orientation
from tests.meshes import disk_grid, spherical_cap


def test_hand_case() -> None:
    o = consistent_orientation(np.array([[0, 1, 2], [1, 2, 3], [0, 2, 4]]))
    assert o.F.tolist() == [[0, 1, 2], [1, 3, 2], [0, 2, 4]]
    assert o.flipped.tolist() == [False, True, False] and o.inconsistent_edges == 0


def test_random_flips_undone_and_majority_kept() -> None:
    _, F = disk_grid(6)
    rng = np.random.default_rng(0)
    for frac in (0.1, 0.3):
        flip = rng.random(F.shape[0]) < frac
        G = F.copy()
        G[flip] = G[flip][:, [0, 2, 1]]
        o = consistent_orientation(G)
        np.testing.assert_array_equal(o.F, F)
        np.testing.assert_array_equal(o.flipped, flip)
    # the majority wins: flip 70 % and the whole mesh comes back reversed
    flip = rng.random(F.shape[0]) < 0.7
    G = F.copy()
    G[flip] = G[flip][:, [0, 2, 1]]
    np.testing.assert_array_equal(consistent_orientation(G).F, F[:, [0, 2, 1]])


def test_components_independent_and_order_invariant() -> None:
    _, F1 = disk_grid(3)
    _, F2 = spherical_cap(3)
    n1 = int(F1.max()) + 1
    F = np.vstack([F1, F2[:, [0, 2, 1]] + n1])  # second piece reversed, consistently
    o = consistent_orientation(F)
    np.testing.assert_array_equal(o.F, F)
    perm = np.random.default_rng(2).permutation(F.shape[0])
    np.testing.assert_array_equal(consistent_orientation(F[perm]).F, F[perm])


def test_mobius_strip_reports_conflict() -> None:
    k = 8  # a triangulated Möbius strip: ring of quads with a half twist
    top, bot = np.arange(k), np.arange(k, 2 * k)
    faces = []
    for i in range(k - 1):
        faces += [[top[i], top[i + 1], bot[i]], [top[i + 1], bot[i + 1], bot[i]]]
    faces += [[top[k - 1], bot[0], bot[k - 1]], [bot[0], top[0], bot[k - 1]]]
    o = consistent_orientation(np.array(faces))
    assert o.inconsistent_edges >= 1


def test_failures_and_no_mutation() -> None:
    with pytest.raises(ValueError, match="more than two"):
        consistent_orientation(np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]))
    with pytest.raises(ValueError):
        consistent_orientation(np.zeros((0, 3), dtype=np.int64))
    F = np.array([[0, 1, 2], [1, 2, 3]])
    before = F.copy()
    consistent_orientation(F)
    np.testing.assert_array_equal(F, before)
