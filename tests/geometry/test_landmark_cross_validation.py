import numpy as np
import pytest

from conformorph.geometry.landmark_cross_validation import (
    cross_validate_registration,
    landmark_folds,
)
from conformorph.geometry.mobius_registration import MobiusTransform
from tests.meshes import disk_grid as _disk_grid


def disk_grid(k):
    V, F = _disk_grid(k)
    return V[:, :2], F


def _landmarks(m, seed=0):
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(0, 0.45, m))
    a = rng.uniform(0, 2 * np.pi, m)
    return np.c_[r * np.cos(a), r * np.sin(a)]


def _smooth_warp(P):
    # a smooth, non-Möbius deformation of the disk, zero on the circle
    w = 1 - np.sum(P**2, axis=1)
    return P + 0.08 * w[:, None] * np.c_[np.sin(2 * P[:, 1]), np.sin(3 * P[:, 0])]


def test_landmark_folds_partition():
    f = landmark_folds(10, 3, seed=4)
    assert f.shape == (10,) and set(f.tolist()) == {0, 1, 2}
    assert sorted(np.bincount(f).tolist()) == [3, 3, 4]
    assert np.array_equal(f, landmark_folds(10, 3, seed=4))  # reproducible
    assert np.array_equal(np.sort(landmark_folds(5, 5)), np.arange(5))  # leave-one-out
    with pytest.raises(ValueError):
        landmark_folds(5, 1)
    with pytest.raises(ValueError):
        landmark_folds(5, 6)


def test_exact_mobius_data_is_predicted_at_held_out_landmarks():
    # hand-worked: Q = M(P) exactly, so the MT fitted to any subset is M itself and
    # predicts every held-out landmark; DMT adds a zero deformation
    uv, F = disk_grid(8)
    P = _landmarks(20)
    Q = MobiusTransform(0.15 - 0.1j, 0.4).apply(P)
    for method in ("mt", "dmt"):
        cv = cross_validate_registration(P, Q, uv, F, method=method, folds=5)
        assert cv.E_D_held_out < 1e-7 and cv.E_D_fitted < 1e-7
        np.testing.assert_allclose(cv.held_out_uv, Q, atol=1e-7)
        assert cv.folded_triangles == [0] * 5 and cv.folded_triangles_fitted == 0


def test_invariants_dmt_interpolates_but_not_held_out():
    uv, F = disk_grid(10)
    P = _landmarks(30, seed=1)
    Q = _smooth_warp(P)
    mt = cross_validate_registration(P, Q, uv, F, method="mt", folds=6)
    dmt = cross_validate_registration(P, Q, uv, F, method="dmt", folds=6)
    # every landmark is held out exactly once
    assert np.array_equal(np.bincount(dmt.folds), [5] * 6)
    # DMT interpolates the landmarks it sees, so the fitted error is ~0 …
    assert dmt.E_D_fitted < 1e-9 < mt.E_D_fitted
    # … but not the held-out ones; yet it predicts them better than MT
    assert dmt.E_D_held_out > 1e-4
    assert dmt.E_D_held_out < 0.5 * mt.E_D_held_out
    assert mt.E_D_held_out >= mt.E_D_fitted - 1e-12
    assert dmt.folded_triangles_fitted == 0 and max(dmt.folded_triangles) == 0
    # a per-landmark kernel scale is subset with the folds (no error, same shapes)
    s = np.linspace(0.5, 2.0, 30)
    dmt_s = cross_validate_registration(P, Q, uv, F, method="dmt", folds=6, kernel_scale=s)
    assert dmt_s.held_out_uv.shape == (30, 2)


def test_held_out_error_converges_with_landmark_density():
    # refinement: the thin plate predicts a smooth warp better from denser landmarks
    uv, F = disk_grid(10)
    errs = []
    for m in (12, 48, 192):
        P = _landmarks(m, seed=2)
        cv = cross_validate_registration(P, _smooth_warp(P), uv, F, method="dmt", folds=6)
        errs.append(cv.E_D_held_out / np.sqrt(m))  # rms per landmark
    assert errs[0] > 2 * errs[1] > 4 * errs[2]


def test_errors():
    uv, F = disk_grid(6)
    P = _landmarks(6)
    with pytest.raises(ValueError, match="fewer than 3"):
        cross_validate_registration(P[:4], P[:4], uv, F, method="mt", folds=2)
    with pytest.raises(ValueError, match="kernel_scale"):
        cross_validate_registration(P, P, uv, F, method="dmt", folds=3, kernel_scale=np.ones(5))
    with pytest.raises(ValueError, match="both be"):
        cross_validate_registration(P, P[:5], uv, F, method="dmt")
