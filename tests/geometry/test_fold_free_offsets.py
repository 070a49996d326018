"""conformorph.geometry.fold_free_offsets: the fold-free part of a planar map's vertex offsets."""

import numpy as np
import pytest

from conformorph.geometry.flipped_triangles import signed_areas_2d
from conformorph.geometry.fold_free_offsets import fold_free_offsets


def grid(k: int) -> tuple[np.ndarray, np.ndarray]:
    """A (k+1)² vertex grid of the unit square, two counter-clockwise triangles per cell."""
    x, y = np.meshgrid(np.linspace(0, 1, k + 1), np.linspace(0, 1, k + 1))
    V = np.column_stack([x.ravel(), y.ravel()])
    idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
    a, b, c, d = (
        idx[:-1, :-1].ravel(),
        idx[:-1, 1:].ravel(),
        idx[1:, :-1].ravel(),
        idx[1:, 1:].ravel(),
    )
    F = np.vstack([np.column_stack([a, b, d]), np.column_stack([a, d, c])])
    return V, F


def test_hand_worked_square():
    # vertex 3 pushed across the diagonal folds triangle (1, 3, 2); its one ring is
    # the whole square, so both moved vertices lose their offsets in one round
    base = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    d = np.array([[0.1, 0.0], [0.0, 0.0], [0.0, 0.0], [-2.0, -2.0]])
    r = fold_free_offsets(base, base, d, F)
    assert r.rounds == 1
    assert r.dropped.tolist() == [True, False, False, True]
    assert np.all(r.offsets == 0.0)


def test_offsets_that_fold_nothing_are_kept_whole():
    V, F = grid(6)
    d = 0.01 * np.sin(7 * V[:, ::-1])
    r = fold_free_offsets(V, V, d, F)
    assert r.rounds == 0 and not r.dropped.any()
    np.testing.assert_array_equal(r.offsets, d)


def test_a_local_fold_is_dropped_locally_and_nothing_folds():
    V, F = grid(12)
    d = np.tile([0.004, -0.003], (V.shape[0], 1))  # harmless everywhere
    centre = int(np.argmin(np.linalg.norm(V - 0.5, axis=1)))
    d[centre] = [0.3, 0.3]  # jumps over several neighbours
    ref = signed_areas_2d(V, F)
    r = fold_free_offsets(V, V, d, F)
    assert np.all(signed_areas_2d(V + r.offsets, F) * ref > 0)
    assert r.dropped[centre]
    far = np.linalg.norm(V - V[centre], axis=1) > 0.3
    np.testing.assert_array_equal(r.offsets[far], d[far])
    assert r.dropped.sum() < 0.1 * V.shape[0]


def test_clockwise_reference_orientation():
    V, F = grid(4)
    Fc = F[:, ::-1]  # every triangle clockwise in its reference layout
    d = np.zeros_like(V)
    d[7] = [0.6, 0.0]
    ref = signed_areas_2d(V, Fc)
    r = fold_free_offsets(V, V, d, Fc)
    assert np.all(signed_areas_2d(V + r.offsets, Fc) * ref > 0)
    assert r.dropped[7]


def test_random_offsets_always_end_fold_free():
    rng = np.random.default_rng(3)
    V, F = grid(10)
    ref = signed_areas_2d(V, F)
    for scale in (0.02, 0.05, 0.2):
        d = scale * rng.standard_normal(V.shape)
        r = fold_free_offsets(V, V, d, F)
        assert np.all(signed_areas_2d(V + r.offsets, F) * ref > 0)
        kept = ~r.dropped
        np.testing.assert_array_equal(r.offsets[kept], d[kept])


def test_bad_inputs():
    V, F = grid(2)
    with pytest.raises(ValueError, match="source_uv, base and offsets"):
        fold_free_offsets(V, V, np.zeros((3, 2)), F)
    with pytest.raises(ValueError, match="source_uv, base and offsets"):
        fold_free_offsets(V[:3], V, np.zeros_like(V), F)
    with pytest.raises(ValueError, match="F must be"):
        fold_free_offsets(V, V, np.zeros_like(V), F[:, :2])
    folded = V.copy()
    folded[4] = [5.0, 5.0]
    with pytest.raises(ValueError, match="base map folds"):
        fold_free_offsets(V, folded, np.zeros_like(V), F)


def test_min_jacobian_drops_offsets_that_nearly_fold():
    # vertex 3 moved to (0.52, 0.52): triangle (1, 3, 2) keeps its orientation but its
    # area goes from 1/2 to 0.02, a Jacobian of 0.04 (by hand: |(-0.48)(1) - (0.52)(-1)| / 2)
    base = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    d = np.zeros((4, 2))
    d[3] = [-0.48, -0.48]
    assert not fold_free_offsets(base, base, d, F).dropped.any()
    assert not fold_free_offsets(base, base, d, F, min_jacobian=0.03).dropped.any()
    r = fold_free_offsets(base, base, d, F, min_jacobian=0.05)
    assert r.dropped.tolist() == [False, False, False, True] and r.rounds == 1
    # a base already below the floor keeps an offset that does not lower it further
    thin = base + d
    up = np.zeros((4, 2))
    up[3] = [0.01, 0.01]  # Jacobian 0.04 → 0.06, still below the floor 0.1
    r = fold_free_offsets(base, thin, up, F, min_jacobian=0.1)
    assert not r.dropped.any()
    r = fold_free_offsets(base, thin, -up, F, min_jacobian=0.1)  # lowers it: dropped
    assert r.dropped.tolist() == [False, False, False, True]
    with pytest.raises(ValueError, match="min_jacobian"):
        fold_free_offsets(base, base, d, F, min_jacobian=-1.0)
