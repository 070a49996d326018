"""Tests of conformorph.geometry.morph_metrics_2d."""

import numpy as np
import pytest

from conformorph.geometry.morph_metrics_2d import morph_metrics_2d

V = np.array([[0.0, 0], [1, 0], [0, 1], [1, 1]])
F = np.array([[0, 1, 2], [1, 3, 2]])


def test_hand_worked_growth_and_squeeze():
    grow = np.stack([V, 1.2 * V, 1.5 * V])
    m = morph_metrics_2d(V, F, grow)
    assert m.flipped_per_frame == (0, 0, 0)
    assert m.min_area_ratio == pytest.approx(1.0) and m.max_area_ratio == pytest.approx(2.25)
    assert m.monotone_strain_fraction == 1.0 and m.no_squeezing
    # shrink to half area then come back to the source: excess 0.5 > 5 %
    squeeze = np.stack([V, V * np.sqrt(0.5), V])
    m = morph_metrics_2d(V, F, squeeze)
    assert m.max_squeeze_excess == pytest.approx(0.5)
    assert not m.no_squeezing and m.no_squeeze_fraction == 0.0
    assert m.monotone_strain_fraction == 0.0


def test_flip_counted():
    X = V.copy()
    X[3] = [-1.0, -1.0]
    m = morph_metrics_2d(V, F, np.stack([V, X]))
    assert m.flipped_per_frame == (0, 1)
    assert m.as_dict()["total_flipped"] == 1


def test_rigid_and_scale_invariance():
    rng = np.random.default_rng(0)
    seq = np.stack([V, V + 0.1 * rng.standard_normal(V.shape), V * [1.3, 0.8]])
    base = morph_metrics_2d(V, F, seq).as_dict()
    th = 0.4
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    for s in (1e-8, 1e8):
        d = morph_metrics_2d(s * V, F, s * seq @ R.T + s).as_dict()
        for k, v in base.items():
            assert d[k] == pytest.approx(v, rel=1e-6, abs=1e-9), k


def test_validation_and_no_mutation():
    with pytest.raises(ValueError):
        morph_metrics_2d(V, F, V)
    seq = np.stack([V, 2 * V])
    c = seq.copy()
    morph_metrics_2d(V, F, seq)
    assert np.array_equal(seq, c)


def test_step_ratio_tells_an_even_pace_from_a_snap():
    V = np.array([[0.0, 0], [1, 0], [0, 1]])
    Fs = np.array([[0, 1, 2]])
    t = np.linspace(0, 1, 11)
    even = np.stack([V + [2.0 * s, 0.0] for s in t])  # steps of 0.2 each
    m = morph_metrics_2d(V, Fs, even)
    assert m.max_step_ratio == pytest.approx(1.0) and m.max_step_frame in range(1, 11)
    # hold still for 9 frames, then jump the whole way: 10 steps, one of length 2
    snap = np.stack([V] * 10 + [V + [2.0, 0.0]])
    m = morph_metrics_2d(V, Fs, snap)
    assert m.max_step_ratio == pytest.approx(10.0) and m.max_step_frame == 10
    # invariant under a rigid motion and a uniform scale of the whole sequence
    R = np.array([[0.6, -0.8], [0.8, 0.6]])
    moved = morph_metrics_2d(3 * V @ R.T, Fs, 3 * snap @ R.T + [5.0, -1.0])
    assert moved.max_step_ratio == pytest.approx(10.0)
    # a still sequence, and two frames: nothing to pace
    assert morph_metrics_2d(V, Fs, np.stack([V] * 4)).max_step_ratio == 1.0
    assert morph_metrics_2d(V, Fs, np.stack([V, 2 * V])).max_step_ratio == 1.0
