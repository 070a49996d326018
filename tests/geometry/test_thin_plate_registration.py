import numpy as np
import pytest

from conformorph.geometry.thin_plate_registration import (
    TPS_TIKHONOV_EPS,
    ThinPlateDeformation,
    thin_plate_registration,
)


def _landmarks(m=25, seed=0, rmax=0.6):
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(0, rmax, m))
    a = rng.uniform(0, 2 * np.pi, m)
    return np.c_[r * np.cos(a), r * np.sin(a)]


def test_interpolates_landmarks_exactly_and_fixes_circle():
    P = _landmarks()
    Q = P + np.random.default_rng(1).normal(0, 0.01, P.shape)
    d, info = thin_plate_registration(P, Q)
    assert info.solver == "tps_interpolation"
    np.testing.assert_allclose(d.apply(P), Q, atol=1e-10)
    a = np.linspace(0, 2 * np.pi, 100)
    circle = np.c_[np.cos(a), np.sin(a)]
    np.testing.assert_allclose(d.apply(circle), circle, atol=1e-12)


def test_kernel_matrix_is_scaled_r2_log_r_and_zero_at_the_centres():
    C = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, -0.25]])
    s = np.array([1.0, 2.0, 0.5])
    d = ThinPlateDeformation(C, s, np.zeros((3, 2)), np.zeros((3, 2)), True)
    x = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.0]])
    r = np.linalg.norm(x[:, None] - C[None], axis=2)
    want = np.where(r > 0, r**2 * np.log(np.where(r > 0, r, 1.0)), 0.0) * s
    K = d.kernel_matrix(x)
    np.testing.assert_allclose(K, want, rtol=1e-12, atol=1e-300)
    assert abs(K[0, 0]) < 1e-300 and abs(K[2, 1]) < 1e-300  # ψ(0) = 0
    assert K[1, 0] == 0.0  # r = 1: log 1 = 0
    np.testing.assert_allclose(K[1, 1], 2.0 * 0.25 * np.log(0.5), rtol=1e-14)


def test_identity_when_landmarks_agree():
    P = _landmarks()
    d, info = thin_plate_registration(P, P)
    x = _landmarks(200, 5, 0.99)
    np.testing.assert_allclose(d.apply(x), x, atol=1e-13)
    assert info.rms_after == 0.0


def test_affine_motion_reproduced_without_taper():
    # with the affine part and no taper, an affine landmark motion is reproduced everywhere
    P = _landmarks()
    A = np.array([[1.02, 0.01], [-0.02, 0.98]])
    Q = P @ A.T + [0.01, -0.02]
    d, _ = thin_plate_registration(P, Q, boundary_taper=False)
    x = _landmarks(100, 7, 0.9)
    np.testing.assert_allclose(d.apply(x), x @ A.T + [0.01, -0.02], atol=1e-9)
    np.testing.assert_allclose(d.alpha, 0.0, atol=1e-9)


def test_paper_solvers_qr_and_tikhonov():
    P = _landmarks(30)
    Q = P + 0.01 * np.sin(3 * P)
    # n < m: least squares by QR (paper's basis only)
    d, info = thin_plate_registration(P, Q, centers=P[:10], affine=False)
    assert info.solver == "qr" and info.regularization == 0
    assert info.rms_after < info.rms_before
    # n > m: Tikhonov with ε = 5e-3
    C = _landmarks(60, 9)
    d, info = thin_plate_registration(P, Q, centers=C, affine=False)
    assert info.solver == "tikhonov" and info.regularization == TPS_TIKHONOV_EPS
    assert info.rms_after < info.rms_before


def test_jacobian_matches_finite_differences_and_scale_only_matters_with_tikhonov():
    P = _landmarks(20, 2)
    Q = P + np.random.default_rng(3).normal(0, 0.01, P.shape)
    s = np.random.default_rng(4).uniform(0.5, 2.0, 20)
    d, _ = thin_plate_registration(P, Q, kernel_scale=s)
    x = _landmarks(30, 8, 0.8) + 1e-3
    J = d.jacobian(x)
    h = 1e-6
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        fd = (d.apply(x + e) - d.apply(x - e)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-6)
    # the paper's basis (no affine part), n = m, QR: an exact fit, the scale is irrelevant
    q1, i1 = thin_plate_registration(P, Q, affine=False)
    q2, _ = thin_plate_registration(P, Q, affine=False, kernel_scale=s)
    assert i1.solver == "qr"
    np.testing.assert_allclose(q1.apply(x), q2.apply(x), atol=1e-8)
    t1, _ = thin_plate_registration(P, Q, regularization=1e-2)
    t2, _ = thin_plate_registration(P, Q, kernel_scale=s, regularization=1e-2)
    assert np.abs(t1.apply(x) - t2.apply(x)).max() > 1e-6


def test_rotation_equivariance_and_permutation():
    P = _landmarks()
    Q = P + np.random.default_rng(5).normal(0, 0.01, P.shape)
    phi = 0.9
    R = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    d, _ = thin_plate_registration(P, Q)
    dr, _ = thin_plate_registration(P @ R.T, Q @ R.T)
    x = _landmarks(50, 6, 0.9)
    np.testing.assert_allclose(dr.apply(x @ R.T), d.apply(x) @ R.T, atol=1e-10)
    perm = np.random.default_rng(6).permutation(P.shape[0])
    dp, _ = thin_plate_registration(P[perm], Q[perm])
    np.testing.assert_allclose(dp.apply(x), d.apply(x), atol=1e-10)


def test_validation_and_no_mutation():
    P = _landmarks(5)
    Q = P + 0.01
    P0, Q0 = P.copy(), Q.copy()
    thin_plate_registration(P, Q)
    np.testing.assert_array_equal(P, P0)
    np.testing.assert_array_equal(Q, Q0)
    with pytest.raises(ValueError):
        thin_plate_registration(P[:2], Q[:2])
    with pytest.raises(ValueError):
        thin_plate_registration(P, Q, kernel_scale=-np.ones(5))
    with pytest.raises(ValueError):
        thin_plate_registration(np.vstack([P, [[1.0, 0.0]]]), np.vstack([Q, [[1.0, 0.0]]]))
