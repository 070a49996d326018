import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conformorph.geometry import (
    boundary_loop,
    cotangent_laplacian,
    mean_curvature,
    mean_curvature_vector,
    vertex_areas,
)
from conformorph.geometry.conformal_factor import conformal_factor
from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.morph_frames import (
    PCG_RTOL,
    FrameSolveOptions,
    HomotopyKeys,
    linear_vertex_frames,
    morph_frames,
)
from conformorph.geometry.rigid_alignment import SimilarityTransform


def _frames(
    F,
    b,
    times,
    uv,
    lam,
    curv,
    bnd,
    te,
    *,
    transforms=None,
    key_lengths=None,
    key_positions=None,
    **solve,
):
    """morph_frames with the key arrays positional, as the tests build them."""
    keys = HomotopyKeys(
        times,
        uv,
        lam,
        curv,
        bnd,
        transforms=transforms,
        key_lengths=key_lengths,
        key_positions=key_positions,
    )
    return morph_frames(F, b, keys, te, FrameSolveOptions(**solve))


def _disk(levels=3):
    return refine_disk_mesh(*landmark_disk_mesh(np.array([[0.05, 0.02]]), n_boundary=16), levels)


def _cap(uv, h):
    """Spherical-cap-like graph over the disk, parameterised by the disk itself (not conformal,
    but a fixed parameterisation is all the homotopy needs for these tests)."""
    return np.c_[uv, h * (1 - (uv**2).sum(axis=1))]


def _keys(uv, F, hs):
    b = boundary_loop(F)
    X = np.stack([_cap(uv, h) for h in hs])
    return (
        b,
        np.stack([uv] * len(hs)),
        np.stack([conformal_factor(x, F, uv) for x in X]),
        np.stack([mean_curvature_vector(x, F) for x in X]),
        np.stack([mean_curvature(x, F) for x in X]),
        X,
    )


def test_flat_keys_give_flat_frames():
    uv, F = _disk(2)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.0, 0.0])
    fr = _frames(F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b], np.array([0.5, 2.0]))
    np.testing.assert_allclose(fr.V[:, :, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(fr.V[0, :, :2], uv, atol=1e-12)  # harmonic = identity for a plane
    assert fr.method == "vector" and fr.iterations == [1, 1]


def test_keys_reproduced_and_inbetween_between_keys():
    uv, F = _disk(3)
    b, K_uv, K_lam, K_Hn, K_H, X = _keys(uv, F, [0.1, 0.3])
    # curvature data consistent with the disk Laplacian (this graph parameterisation is not
    # conformal): L_uv X = 2 λ A_uv Hn, so the keys must be reproduced to solver precision
    L = cotangent_laplacian(uv, F)
    A = vertex_areas(uv, F)
    K_Hn = np.stack([(L @ x) / (2 * lam * A)[:, None] for x, lam in zip(X, K_lam, strict=True)])
    t = np.array([0.0, 1.0])
    fr = _frames(F, b, t, K_uv, K_lam, K_Hn, X[:, b], np.array([0.0, 0.5, 1.0]))
    for k, i in ((0, 0), (2, 1)):
        err = np.abs(fr.V[k] - X[i]).max()
        assert err < 1e-6, err  # the vector homotopy is one exact solve at the keys
    z_mid = fr.V[1, :, 2].max()
    assert 0.1 < z_mid < 0.3
    # the scalar homotopy (Algorithm 1) reproduces the keys approximately
    fs = _frames(F, b, t, K_uv, K_lam, K_H, X[:, b], np.array([1.0]))
    assert fs.method == "scalar"
    assert np.abs(fs.V[0] - X[1]).max() < 0.05


def test_rigid_part_is_put_back():
    uv, F = _disk(2)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.2, 0.2])
    R1 = Rotation.from_rotvec([0, 0, np.pi / 2]).as_matrix()
    T = [SimilarityTransform.identity(), SimilarityTransform(R1, np.array([1.0, 0, 0]), 2.0)]
    fr = _frames(
        F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b], np.array([0.5, 1.0]), transforms=T
    )
    np.testing.assert_allclose(fr.placed(1), T[1].apply(fr.V[1]), atol=1e-12)
    np.testing.assert_allclose(fr.transforms[0].scale, np.sqrt(2.0))
    half = Rotation.from_rotvec([0, 0, np.pi / 4]).as_matrix()
    np.testing.assert_allclose(fr.transforms[0].rotation, half, atol=1e-12)


def test_linear_vertex_frames_exact_on_linear_paths():
    rng = np.random.default_rng(0)
    A, B = rng.normal(size=(2, 10, 3))
    t = np.array([0.0, 1.0, 3.0])
    keys = np.stack([A + s * B for s in t])
    te = np.array([-0.5, 0.2, 2.0, 3.5])
    np.testing.assert_allclose(
        linear_vertex_frames(t, keys, te), A[None] + te[:, None, None] * B[None], atol=1e-12
    )


def test_validation_and_no_mutation():
    uv, F = _disk(1)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.1, 0.2])
    c = [a.copy() for a in (K_uv, K_lam, K_Hn)]
    _frames(F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b], np.array([0.5]))
    for a, a0 in zip((K_uv, K_lam, K_Hn), c, strict=True):
        np.testing.assert_array_equal(a, a0)
    with pytest.raises(ValueError):
        _frames(F, b, np.array([1.0, 0.0]), K_uv, K_lam, K_Hn, X[:, b], np.array([0.5]))
    with pytest.raises(ValueError):
        _frames(F, b, np.array([0.0, 1.0]), K_uv, -K_lam, K_Hn, X[:, b], np.array([0.5]))
    with pytest.raises(ValueError):
        _frames(F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b[:-1]], np.array([0.5]))


def test_metric_homotopy_pcg_equals_direct_and_reproduces_keys():
    from conformorph.geometry.intrinsic_laplacian import edge_lengths

    uv, F = _disk(3)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.1, 0.4])
    ell = np.stack([edge_lengths(x, F) for x in X])
    te = np.linspace(0.0, 1.0, 9)
    args = (F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b], te)
    direct = _frames(*args, key_lengths=ell, pcg_frames=False)
    pcg = _frames(*args, key_lengths=ell, pcg_frames=True, pcg_rtol=1e-12)
    assert direct.factorizations == te.size and pcg.factorizations < te.size
    np.testing.assert_allclose(pcg.V, direct.V, atol=1e-9)
    # the default tolerance: still far below the homotopy's own error
    loose = _frames(*args, key_lengths=ell)
    np.testing.assert_allclose(loose.V, direct.V, atol=1e-5)
    # the metric form reproduces the keys exactly (their Laplacian is their own)
    np.testing.assert_allclose(direct.V[0], X[0], atol=1e-9)
    np.testing.assert_allclose(direct.V[-1], X[1], atol=1e-9)
    assert direct.method == "vector-metric" and direct.clamped_triangles == 0
    with pytest.raises(ValueError, match="vector"):
        _frames(F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_lam, X[:, b], te, key_lengths=ell)


def test_metric_frames_on_threads_equal_one_thread(monkeypatch):
    import importlib

    from conformorph.geometry.intrinsic_laplacian import edge_lengths

    mf = importlib.import_module(
        "conformorph.geometry.morph_frames"
    )  # the module, not the function

    uv, F = _disk(3)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.1, 0.4])
    ell = np.stack([edge_lengths(x, F) for x in X])
    te = np.linspace(0.0, 1.0, 3 * mf.MIN_FRAMES_PER_THREAD)
    args = (F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b], te)
    th = importlib.import_module("conformorph.geometry.threads")
    monkeypatch.setattr(th, "available_threads", lambda: 1)
    one = _frames(*args, key_lengths=ell, pcg_rtol=1e-12)
    monkeypatch.setattr(th, "available_threads", lambda: 3)
    three = _frames(*args, key_lengths=ell, pcg_rtol=1e-12)
    # three runs of consecutive frames, each opening with a factorisation of its own
    assert three.factorizations >= 3 and len(three.iterations) == te.size
    for k in (0, mf.MIN_FRAMES_PER_THREAD, 2 * mf.MIN_FRAMES_PER_THREAD):
        assert three.iterations[k] == 1
    np.testing.assert_allclose(three.V, one.V, atol=1e-9)
    np.testing.assert_array_equal(three.uv, one.uv)


def test_extrapolate_is_exact_for_quadratics():
    from conformorph.geometry.morph_frames import _extrapolate

    # hand-worked: x(t) = 1 + 2t − t², known at t = 0, 1, 3 → x(4) = −7
    ts = [0.0, 1.0, 3.0]
    xs = [np.full((2, 3), 1 + 2 * t - t * t) for t in ts]
    np.testing.assert_allclose(_extrapolate(ts, xs, 4.0), -7.0)
    # equally spaced: 3a − 3b + c; two points: linear; one: constant
    np.testing.assert_allclose(_extrapolate([1.0, 2.0], xs[:2], 3.0), 2 * xs[1] - xs[0])
    np.testing.assert_allclose(_extrapolate([5.0], xs[:1], 9.0), xs[0])


def _pcg(A, b, fac, x0, rtol):
    """conformorph.geometry.sparse_factor.preconditioned_cg with the frames' iteration cap."""
    from conformorph.geometry.morph_frames import PCG_MAX_ITERATIONS
    from conformorph.geometry.sparse_factor import preconditioned_cg

    return preconditioned_cg(A, b, fac, x0, rtol=rtol, max_iterations=PCG_MAX_ITERATIONS)


def test_lockstep_pcg_matches_direct_and_counts_iterations():
    import scipy.sparse as sp

    from conformorph.geometry.sparse_factor import factorize

    # 1D Dirichlet Laplacian and a perturbed copy (a "nearby frame")
    n = 60
    main = np.full(n, 2.0)
    A0 = sp.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1], format="csc")
    A1 = sp.diags([-np.ones(n - 1), main + 0.001, -np.ones(n - 1)], [-1, 0, 1], format="csc")
    b = np.random.default_rng(1).standard_normal((n, 3))
    x_exact = factorize(A1).solve(b)
    # exact preconditioner: one iteration
    x, it = _pcg(A1, b, factorize(A1), np.zeros((n, 3)), rtol=1e-10)
    assert x is not None and it == 1
    np.testing.assert_allclose(x, x_exact, atol=1e-9)
    # nearby preconditioner: converges in a few iterations, to the same answer
    x, it = _pcg(A1, b, factorize(A0), np.zeros((n, 3)), rtol=1e-10)
    assert x is not None and 1 < it <= 8
    np.testing.assert_allclose(x, x_exact, atol=1e-8)
    # the exact answer as a start: no iteration
    x, it = _pcg(A1, b, factorize(A0), x_exact, rtol=1e-10)
    assert it == 0
    # a poor preconditioner within too few iterations: None (the caller refactorises)
    far = sp.identity(n, format="csc")
    x, _ = _pcg(A1, b, factorize(far), np.zeros((n, 3)), rtol=1e-12)
    assert x is None


def test_screened_metric_homotopy_reproduces_keys_and_tends_to_the_position_spline():
    from conformorph.geometry.intrinsic_laplacian import edge_lengths
    from conformorph.geometry.spline_homotopy import SplineHomotopy

    uv, F = _disk(3)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.1, 0.4])
    ell = np.stack([edge_lengths(x, F) for x in X])
    te = np.array([0.0, 0.3, 0.7, 1.0])
    args = (F, b, np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b], te)
    plain = _frames(*args, key_lengths=ell, pcg_frames=False)
    zero = _frames(*args, key_lengths=ell, key_positions=X, screen_weight=0.0, pcg_rtol=1e-12)
    np.testing.assert_allclose(zero.V, plain.V, atol=1e-9)  # w = 0: the metric homotopy
    spline = SplineHomotopy(np.array([0.0, 1.0]), X)(te)
    gaps = []
    for w in (1.0, 1e2, 1e4, 1e6):
        fr = _frames(*args, key_lengths=ell, key_positions=X, screen_weight=w, pcg_rtol=1e-12)
        # every key is reproduced for any weight (L_i X_i = 2 M_i Hn_i and the spline passes X_i)
        np.testing.assert_allclose(fr.V[0], X[0], atol=1e-8)
        np.testing.assert_allclose(fr.V[-1], X[1], atol=1e-8)
        gaps.append(np.abs(fr.V[1:3] - spline[1:3]).max())
    # convergence: as w grows the frames tend to the position spline, monotonically
    assert all(g1 > g2 for g1, g2 in zip(gaps, gaps[1:], strict=False))
    assert gaps[-1] < 1e-3 * gaps[0]
    with pytest.raises(ValueError, match="key_positions"):
        _frames(*args, key_lengths=ell, screen_weight=1.0)
    with pytest.raises(ValueError, match="metric"):
        _frames(*args, key_positions=X, screen_weight=1.0)
    with pytest.raises(ValueError, match="≥ 0"):
        _frames(*args, key_lengths=ell, key_positions=X, screen_weight=-1.0)


def test_lockstep_pcg_with_a_zero_column():
    # a planar frame has z ≡ 0: that column converges at once and must not stop the others
    import scipy.sparse as sp

    from conformorph.geometry.sparse_factor import factorize

    n = 40
    A0 = sp.diags([-np.ones(n - 1), np.full(n, 2.0), -np.ones(n - 1)], [-1, 0, 1], format="csc")
    A1 = (A0 + sp.identity(n) * 1e-3).tocsc()
    b = np.zeros((n, 3))
    b[:, :2] = np.random.default_rng(3).standard_normal((n, 2))
    x, it = _pcg(A1, b, factorize(A0), np.zeros((n, 3)), rtol=1e-10)
    assert x is not None and it >= 1
    np.testing.assert_allclose(x, factorize(A1).solve(b), atol=1e-8)
    assert np.all(x[:, 2] == 0.0)


def test_solve_options_defaults_are_the_former_keyword_defaults_and_keys_default_to_identity():
    o = FrameSolveOptions()
    assert (o.bc_type, o.reuse_operator, o.pcg_frames, o.pcg_rtol, o.screen_weight) == (
        "natural",
        False,
        True,
        PCG_RTOL,
        0.0,
    )
    uv, F = _disk(2)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.0, 0.2])
    keys = HomotopyKeys(np.array([0.0, 1.0]), K_uv, K_lam, K_Hn, X[:, b])
    assert keys.transforms is None and keys.key_lengths is None and keys.key_positions is None
    fr = morph_frames(F, b, keys, np.array([0.0, 1.0]))  # options omitted: the defaults
    same = morph_frames(F, b, keys, np.array([0.0, 1.0]), FrameSolveOptions())
    np.testing.assert_array_equal(fr.V, same.V)
    # no transforms: every frame stays in the aligned frame (identity similarities)
    np.testing.assert_allclose(fr.placed(1), fr.V[1], atol=1e-15)


def test_frames_at_key_times_are_factorised_and_equal_the_keys_solved_alone():
    from conformorph.geometry.intrinsic_laplacian import edge_lengths

    uv, F = _disk(3)
    b, K_uv, K_lam, K_Hn, _, X = _keys(uv, F, [0.1, 0.4, 0.2])
    ell = np.stack([edge_lengths(x, F) for x in X])
    times = np.array([0.0, 1.0, 2.0])
    te = np.linspace(0.0, 2.0, 9)  # key 1 (t = 1) falls inside the run, not at its start
    fr = _frames(F, b, times, K_uv, K_lam, K_Hn, X[:, b], te, key_lengths=ell)
    at_keys = [int(np.flatnonzero(te == t)[0]) for t in times]
    # every key-time frame is a fresh factorisation (1 iteration), the others CG
    assert [fr.iterations[k] for k in at_keys] == [1, 1, 1]
    alone = _frames(F, b, times, K_uv, K_lam, K_Hn, X[:, b], times, key_lengths=ell)
    for i, k in enumerate(at_keys):
        np.testing.assert_array_equal(fr.V[k], alone.V[i])
        np.testing.assert_allclose(fr.V[k], X[i], atol=1e-9)
