"""Tests of conformorph.geometry.strain_system, conformorph.geometry.strain_newton and conformorph.geometry.strain_frames
(W of eq. 4, φ of eq. 9, K of eq. 10; Newton eq. 11, continuation eq. 12; time stepping)."""

from dataclasses import replace

import numpy as np
import pytest

from conformorph.geometry.green_lagrange_strain import green_lagrange_strain
from conformorph.geometry.strain_frames import (
    StrainMorphOptions,
    check_strain_morph_options,
    solve_frame,
    solve_frames,
)
from conformorph.geometry.strain_newton import (
    barrier_newton,
    continuation_newton,
    max_positive_step,
)
from conformorph.geometry.strain_system import StrainSystem
from conformorph.geometry.strain_targets import strain_target


def grid(k: int = 3) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.meshgrid(np.linspace(0, 1, k + 1), np.linspace(0, 1, k + 1))
    V = np.c_[x.ravel(), y.ravel()]
    F = []
    for j in range(k):
        for i in range(k):
            a = j * (k + 1) + i
            F += [[a, a + 1, a + k + 2], [a, a + k + 2, a + k + 1]]
    return V, np.array(F, dtype=np.int64)


def system(V, F):
    # gauge: vertex 0 fixed, vertex k (on the x axis) keeps y = 0
    b = int(np.argmax(V[:, 0] * (V[:, 1] == 0)))
    return StrainSystem(V, F, np.array([0, 1, 2 * b + 1])), b


def test_system_at_rest_has_zero_energy_residual_and_a_symmetric_tangent():
    V, F = grid()
    sysm, _ = system(V, F)
    eps0 = np.zeros((F.shape[0], 3))
    assert sysm.energy(V, eps0) == 0.0
    np.testing.assert_allclose(sysm.residual(V, eps0), 0.0, atol=1e-15)
    phi, K = sysm.tangent(V, eps0)
    assert K.shape == (2 * V.shape[0] - 3,) * 2
    np.testing.assert_allclose((K - K.T).toarray(), 0.0, atol=1e-12)
    np.testing.assert_allclose(sysm.det(V), 1.0)


def test_residual_is_the_gradient_of_the_energy():
    V, F = grid()
    sysm, _ = system(V, F)
    rng = np.random.default_rng(0)
    X = V + 0.05 * rng.standard_normal(V.shape)
    eps = 0.1 * rng.standard_normal((F.shape[0], 3))
    phi = sysm.residual(X, eps)
    h = 1e-6
    for k, dof in enumerate(np.flatnonzero(sysm.free)[:6]):
        D = np.zeros_like(X)
        D.reshape(-1)[dof] = h
        fd = (sysm.energy(X + D, eps) - sysm.energy(X - D, eps)) / (2 * h)
        assert phi[k] == pytest.approx(fd, rel=1e-5, abs=1e-9)


def test_max_positive_step_by_hand():
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    F = np.array([[0, 1, 2]])
    sysm = StrainSystem(V, F, np.array([0, 1, 3]))
    # moving vertex 2 down by D: det J = 1 − s, zero at s = 1
    D = np.zeros_like(V)
    D[2, 1] = -1.0
    assert max_positive_step(sysm, V, D) == pytest.approx(1.0)
    assert max_positive_step(sysm, V, -D) == np.inf


@pytest.mark.parametrize("N", [1, 4])
def test_newton_and_continuation_reach_a_uniform_scaling(N):
    V, F = grid()
    sysm, _ = system(V, F)
    s = 1.5
    eps_t = green_lagrange_strain(V, s * V, F)
    res = continuation_newton(sysm, V.copy(), eps_t, N, 1e-12, 30)
    assert res.reason == "converged" and res.continuation == N and res.iterations >= N
    np.testing.assert_allclose(res.X, s * V, atol=1e-9)


def test_barrier_newton_reaches_a_uniform_scaling():
    V, F = grid()
    sysm, _ = system(V, F)
    eps_n = green_lagrange_strain(V, 1.5 * V, F)
    eps_t, d_star = strain_target(eps_n, 1.0, "modified")
    res = barrier_newton(sysm, V.copy(), eps_t, d_star, 1e-12, 30)
    assert res.reason == "converged"
    np.testing.assert_allclose(res.X, 1.5 * V, atol=1e-9)


def test_solve_frame_counts_every_attempt():
    V, F = grid()
    sysm, _ = system(V, F)
    eps_n = green_lagrange_strain(V, 2.0 * V, F)
    eps_t, d_star = strain_target(eps_n, 1.0, "modified")
    opts = StrainMorphOptions(solver="newton", max_iterations=1, max_continuation=4)
    res = solve_frame(sysm, V.copy(), eps_t, d_star, 1e-12, opts)
    # plain Newton (1 iteration allowed), then N = 2 (3 allowed) and N = 4 (5 allowed),
    # each from the warm start; the frame reports the last attempt and every iteration
    tries = [
        continuation_newton(sysm, V.copy(), eps_t, N, 1e-12, 1 + (N > 1) * N) for N in (1, 2, 4)
    ]
    assert all(t.reason != "converged" for t in tries)
    assert res.iterations == sum(t.iterations for t in tries)
    assert res.continuation == 4 and res.reason == tries[-1].reason
    np.testing.assert_array_equal(res.X, tries[-1].X)


def test_solve_frames_at_rest_and_with_intermediate_steps():
    V, F = grid()
    sysm, _ = system(V, F)
    eps_n = green_lagrange_strain(V, 1.5 * V, F)
    times = np.array([0.0, 1.0])
    solved = solve_frames(
        sysm, V, eps_n, times, "linear", 1e-12, StrainMorphOptions(max_time_step=0.25)
    )
    assert solved.stop_reasons == ("converged", "converged")
    np.testing.assert_array_equal(solved.X[0], V)
    assert solved.iterations[0] == 0 and solved.substeps.tolist() == [0, 3]
    np.testing.assert_allclose(solved.X[1], 1.5 * V, atol=1e-9)
    none = solve_frames(
        sysm, V, eps_n, times, "linear", 1e-12, StrainMorphOptions(max_total_iterations=0)
    )
    assert none.stop_reasons[1] == "budget"
    np.testing.assert_array_equal(none.X[1], V)


@pytest.mark.parametrize(
    "bad",
    [
        {"max_iterations": 0},
        {"max_substeps": -1},
        {"tol": 0.0},
        {"max_time_step": 1.5},
        {"max_total_iterations": -1},
        {"max_step_halvings": -1},
        {"stall_iterations": 0},
        {"solver": "gauss"},
        {"predictor": "cubic"},
    ],
)
def test_check_strain_morph_options(bad):
    check_strain_morph_options(StrainMorphOptions())
    with pytest.raises(ValueError):
        check_strain_morph_options(StrainMorphOptions(**bad))


def test_tangent_upper_and_shifted_factorisation_match_the_dense_tangent():
    V, F = grid()
    sysm, _ = system(V, F)
    rng = np.random.default_rng(4)
    X = 1.2 * V + 0.02 * rng.standard_normal(V.shape)
    eps = 0.1 * rng.standard_normal((F.shape[0], 3))
    phi, K = sysm.tangent(X, eps)
    phi2, K2, U = sysm.tangent_upper(X, eps)
    np.testing.assert_array_equal(phi, phi2)
    Kd = K.toarray()
    np.testing.assert_array_equal(K2.toarray(), Kd)
    np.testing.assert_array_equal(U.toarray(), np.triu(Kd))
    for shift in (0.0, 0.5, 3.0):  # one analysis, three numeric factorisations
        x = sysm.factorize(K, U, shift).solve(phi)
        np.testing.assert_allclose(
            x, np.linalg.solve(Kd + shift * np.eye(len(phi)), phi), atol=1e-9
        )
    np.testing.assert_array_equal(K.toarray(), Kd)  # the shift did not touch K


def test_deformation_gradients_and_determinants_by_hand():
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    F = np.array([[0, 1, 2]])
    sysm = StrainSystem(V, F, np.array([0, 1, 3]))
    A = np.array([[2.0, 0.5], [-1.0, 3.0]])
    X = V @ A.T + [4.0, 5.0]  # the affine map x -> A x + c has J = A everywhere
    np.testing.assert_allclose(sysm.jacobians(X)[0], A)
    np.testing.assert_allclose(sysm.det(X), [np.linalg.det(A)])


def test_step_halving_limit_stops_a_folding_path_as_stalled():
    # Newton with one iteration per attempt cannot reach a 2x scaling in one step:
    # every solve fails, so the march halves its steps; the limit ends the call there
    V, F = grid()
    sysm, _ = system(V, F)
    eps_n = green_lagrange_strain(V, 2.0 * V, F)
    times = np.array([0.0, 0.5, 1.0])
    base = StrainMorphOptions(solver="newton", max_iterations=1, max_continuation=1)
    opts = {"max_time_step": 1.0, "max_substeps": 2}
    free = solve_frames(sysm, V, eps_n, times, "linear", 1e-12, replace(base, **opts))
    assert "stalled" not in free.stop_reasons and free.substeps[1] > 0
    for limit in (0, 1):
        cut = solve_frames(
            sysm,
            V,
            eps_n,
            times,
            "linear",
            1e-12,
            replace(base, max_step_halvings=limit, **opts),
        )
        assert cut.stop_reasons == ("converged", "stalled", "stalled")
        # the last solved state (the source) is repeated; the failed attempts are counted
        np.testing.assert_array_equal(cut.X[1], V)
        np.testing.assert_array_equal(cut.X[2], V)
        # one failed solve per level: at t = 0.5, then at t = 0.25 after each halving
        assert cut.iterations[1] == 1 + limit and cut.iterations[2] == 0


def test_barrier_newton_with_chord_steps_reaches_the_same_solution():
    V, F = grid()
    sysm, _ = system(V, F)
    rng = np.random.default_rng(7)
    T = 1.4 * V + 0.03 * rng.standard_normal(V.shape)
    eps_t, d_star = strain_target(green_lagrange_strain(V, T, F), 1.0, "modified")
    calls = []
    factorize = sysm.factorize
    sysm.factorize = lambda *a: calls.append(1) or factorize(*a)  # count factorisations
    full = barrier_newton(sysm, V.copy(), eps_t, d_star, 1e-11, 60)
    n_full = len(calls)
    chord = barrier_newton(sysm, V.copy(), eps_t, d_star, 1e-11, 60, reuse_factor=True)
    assert full.reason == chord.reason == "converged"
    assert len(calls) - n_full < n_full  # some steps reused a factorisation
    np.testing.assert_allclose(chord.X, full.X, atol=1e-8)
    # the energy's gradient vanishes at both (W is minimised: T itself has W = 0 up to
    # the gauge, so both reach a zero-energy configuration)
    assert sysm.energy(chord.X, eps_t) < 1e-16


def test_stall_rule_on_progress_lets_a_halving_path_recover():
    # Newton with 5 iterations per attempt cannot take a step of 1/2 towards a 3x
    # scaling: the march halves each step many times, and then advances
    V, F = grid()
    sysm, _ = system(V, F)
    eps_n = green_lagrange_strain(V, 3.0 * V, F)
    times = np.array([0.0, 0.5, 1.0])
    base = StrainMorphOptions(
        solver="newton",
        max_iterations=5,
        max_continuation=1,
        predictor="previous",
        max_time_step=0.5,
        max_substeps=6,
    )
    free = solve_frames(sysm, V, eps_n, times, "linear", 1e-12, base)
    assert free.stop_reasons == ("converged",) * 3 and free.substeps[1] > 8
    # a count of halvings stops it although it would recover
    for limit in (4, 8):
        cut = solve_frames(
            sysm, V, eps_n, times, "linear", 1e-12, replace(base, max_step_halvings=limit)
        )
        assert cut.stop_reasons[1:] == ("stalled", "stalled")
    # the progress rule lets it through (the same frames), and stops it once the
    # iterations without progress in t exceed the limit
    ok = solve_frames(sysm, V, eps_n, times, "linear", 1e-12, replace(base, stall_iterations=80))
    assert ok.stop_reasons == free.stop_reasons
    np.testing.assert_array_equal(ok.X, free.X)
    tight = solve_frames(sysm, V, eps_n, times, "linear", 1e-12, replace(base, stall_iterations=30))
    assert tight.stop_reasons[1:] == ("stalled", "stalled")
    assert 30 <= tight.iterations[1] < free.iterations[1]
    np.testing.assert_array_equal(tight.X[2], tight.X[1])  # the last solved state repeated
