import numpy as np
import pytest

from conformorph.geometry.landmark_smoothing import discrepancy_smoothing
from conformorph.geometry.thin_plate_registration import thin_plate_registration


def _noisy_pairs(m=40, sigma=0.01, seed=0):
    rng = np.random.default_rng(seed)
    P = rng.uniform(-0.5, 0.5, (m, 2))
    smooth = P + 0.15 * np.c_[P[:, 1] ** 2, np.sin(2 * P[:, 0])]
    return P, smooth, smooth + rng.normal(0.0, sigma, (m, 2))


def _rms(d, P, Q):
    return float(np.sqrt(np.mean(np.sum((d.apply(P) - Q) ** 2, axis=1))))


def test_smoothing_zero_is_the_interpolation_and_large_is_the_affine_fit():
    P, _, Q = _noisy_pairs()
    d0, info0 = thin_plate_registration(P, Q, smoothing=np.zeros(len(P)))
    assert info0.solver == "tps_smoothing" and _rms(d0, P, Q) < 1e-9
    # hand-worked limit: Λ → ∞ leaves no kernel, i.e. the affine least-squares fit of the
    # tapered displacement (Q − P) / (1 − |P|²)
    d_inf, _ = thin_plate_registration(P, Q, smoothing=np.full(len(P), 1e9))
    w = 1.0 - np.sum(P**2, axis=1)
    A = np.c_[np.ones(len(P)), P]
    beta = np.linalg.lstsq(A, (Q - P) / w[:, None], rcond=None)[0]
    np.testing.assert_allclose(d_inf.apply(P), P + w[:, None] * (A @ beta), atol=1e-6)
    # the residual grows with the smoothing
    res = [
        _rms(thin_plate_registration(P, Q, smoothing=np.full(len(P), s))[0], P, Q)
        for s in (1e-6, 1e-4, 1e-2, 1.0)
    ]
    assert all(a < b for a, b in zip(res, res[1:], strict=False))


def test_a_landmark_with_more_smoothing_is_followed_less():
    P, _, Q = _noisy_pairs(m=12)
    lam = np.full(12, 1e-3)
    lam[3] = 1.0
    d, _ = thin_plate_registration(P, Q, smoothing=lam)
    r = np.linalg.norm(d.apply(P) - Q, axis=1)
    assert r[3] > 3 * np.max(np.delete(r, 3))


def test_discrepancy_residual_matches_the_noise_and_removes_it():
    sigma = 0.01
    P, truth, Q = _noisy_pairs(m=60, sigma=sigma)  # a bend 15x the noise
    s = discrepancy_smoothing(P, Q, np.full(60, sigma))
    assert not s.saturated and s.kappa > 0
    assert s.chi == pytest.approx(1.0, abs=1e-3)
    d, _ = thin_plate_registration(P, Q, smoothing=s.smoothing)
    assert _rms(d, P, Q) == pytest.approx(np.sqrt(2) * sigma, rel=1e-2)
    # the smoothed fit is nearer the noise-free correspondence than the interpolation
    d0, _ = thin_plate_registration(P, Q)
    assert _rms(d, P, truth) < 0.8 * _rms(d0, P, truth)


def test_discrepancy_exact_landmarks_and_saturation():
    P, _, Q = _noisy_pairs(m=10)
    s = discrepancy_smoothing(P, Q, np.zeros(10))
    assert s.kappa == 0.0 and np.all(s.smoothing == 0) and not s.saturated
    # noise far above the displacement: even the affine fit is within it
    big = discrepancy_smoothing(P, Q, np.full(10, 1.0))
    assert big.saturated and big.chi < 1.0


def test_discrepancy_is_invariant_to_a_rotation_of_the_disk():
    P, _, Q = _noisy_pairs(m=30)
    c, s_ = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s_], [s_, c]])
    a = discrepancy_smoothing(P, Q, np.full(30, 0.01))
    b = discrepancy_smoothing(P @ R.T, Q @ R.T, np.full(30, 0.01))
    assert b.kappa == pytest.approx(a.kappa, rel=1e-6)
    # and a scaled noise with a scaled displacement about the identity gives the same κ
    # ratio shape: twice the noise needs more smoothing for the same data
    c2 = discrepancy_smoothing(P, Q, np.full(30, 0.02))
    assert c2.kappa > a.kappa


def test_validation():
    P, _, Q = _noisy_pairs(m=5)
    with pytest.raises(ValueError, match="noise"):
        discrepancy_smoothing(P, Q, np.full(5, -1.0))
    with pytest.raises(ValueError, match="noise"):
        discrepancy_smoothing(P, Q, np.ones(4))
    with pytest.raises(ValueError, match="m ≥ 3"):
        discrepancy_smoothing(P[:2], Q[:2], np.ones(2))
    with pytest.raises(ValueError, match="chi"):
        discrepancy_smoothing(P, Q, np.ones(5), chi=0.0)
    with pytest.raises(ValueError, match="smoothing"):
        thin_plate_registration(P, Q, smoothing=np.ones(4))
    with pytest.raises(ValueError, match="centres at the landmarks"):
        thin_plate_registration(P, Q, centers=P[:3], smoothing=np.ones(5))
