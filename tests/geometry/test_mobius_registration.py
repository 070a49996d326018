import numpy as np
import pytest

from conformorph.geometry.mobius_registration import MobiusTransform, mobius_registration


def _landmarks(m=20, seed=0):
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(0, 0.7, m))
    a = rng.uniform(0, 2 * np.pi, m)
    return np.c_[r * np.cos(a), r * np.sin(a)]


def test_hand_worked_values():
    M = MobiusTransform(0.5 + 0j, 0.0)
    # z=0 ↦ -a; z=a ↦ 0; z=1 ↦ 1 (circle point fixed when θ=0 and a real)
    out = M.apply(np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]))
    np.testing.assert_allclose(out, [[-0.5, 0.0], [0.0, 0.0], [1.0, 0.0]], atol=1e-15)
    # |f'(0)|² = (1 - |a|²)² = 0.5625
    np.testing.assert_allclose(M.jacobian_determinant(np.zeros((1, 2))), [0.5625])


def test_disk_automorphism_invariants():
    M = MobiusTransform(0.3 - 0.4j, 1.2)
    a = np.linspace(0, 2 * np.pi, 50)
    circle = np.c_[np.cos(a), np.sin(a)]
    np.testing.assert_allclose(np.linalg.norm(M.apply(circle), axis=1), 1.0, atol=1e-14)
    P = _landmarks()
    assert np.all(np.linalg.norm(M.apply(P), axis=1) < 1)
    np.testing.assert_allclose(M.inverse().apply(M.apply(P)), P, atol=1e-14)


def test_recovers_exact_transform():
    P = _landmarks()
    M = MobiusTransform(-0.25 + 0.1j, -2.0)
    T, info = mobius_registration(P, M.apply(P))
    assert abs(T.a - M.a) < 1e-9
    assert abs(np.angle(np.exp(1j * (T.theta - M.theta)))) < 1e-9
    assert info.error < 1e-10


def test_noisy_fit_beats_identity_and_reordering_invariance():
    P = _landmarks(30, 1)
    M = MobiusTransform(0.2 + 0.2j, 0.3)
    Q = M.apply(P) + np.random.default_rng(2).normal(0, 0.01, P.shape)
    T, info = mobius_registration(P, Q)
    assert info.error < np.sqrt(np.sum((P - Q) ** 2))
    assert info.rms < 0.02
    perm = np.random.default_rng(3).permutation(P.shape[0])
    T2, info2 = mobius_registration(P[perm], Q[perm])
    assert abs(T2.a - T.a) < 1e-7 and abs(info2.error - info.error) < 1e-9


def test_rotation_equivariance():
    # rotating the target by φ rotates the fitted map: θ → θ + φ, a unchanged
    P = _landmarks(15, 4)
    Q = MobiusTransform(0.1 - 0.3j, 0.5).apply(P) + 0.005
    T1, _ = mobius_registration(P, Q)
    phi = 0.7
    Rz = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    T2, _ = mobius_registration(P, Q @ Rz.T)
    assert abs(T2.a - T1.a) < 1e-7
    assert abs(np.angle(np.exp(1j * (T2.theta - T1.theta - phi)))) < 1e-7


def test_validation_and_no_mutation():
    P = _landmarks(5)
    Q = P.copy()
    P0 = P.copy()
    mobius_registration(P, Q)
    np.testing.assert_array_equal(P, P0)
    with pytest.raises(ValueError):
        mobius_registration(P, Q[:4])
    with pytest.raises(ValueError):
        mobius_registration(P[:1], Q[:1])
    with pytest.raises(ValueError):
        mobius_registration(P * 3, Q)
    with pytest.raises(ValueError):
        MobiusTransform(1.0 + 0j, 0.0)
