import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.nonrigid_icp import (
    STIFFNESS_SCHEDULE,
    ICPLandmarks,
    NonrigidICPOptions,
    nonrigid_icp,
)


def _icp(X, F, Xt, Ft, tri, bc, y, *, initial_displacement=None, weights=None, **options):
    """nonrigid_icp with the landmarks positional and the options as keywords."""
    return nonrigid_icp(
        X,
        F,
        Xt,
        Ft,
        ICPLandmarks(tri, bc, y),
        initial_displacement=initial_displacement,
        weights=weights,
        options=NonrigidICPOptions(**options),
    )


def _sheet(levels=3):
    uv, F = refine_disk_mesh(*landmark_disk_mesh(np.array([[0.0, 0.0]]), n_boundary=12), levels)
    return np.c_[uv, np.zeros(len(uv))], F


def _landmarks(X, F, k=6):
    tri = np.linspace(0, F.shape[0] - 1, k).astype(np.int64)
    bc = np.full((k, 3), 1.0 / 3.0)
    return tri, bc, np.einsum("kj,kjd->kd", bc, X[F[tri]])


def _bump_pair():
    """The sheet, its target (lifted by a smooth bump and shifted along its normal) and
    landmarks carried onto the target."""
    X, F = _sheet()
    Xt = X.copy()
    Xt[:, 2] = 0.05 + 0.1 * np.exp(-np.sum(X[:, :2] ** 2, axis=1) / 0.3)
    tri, bc, _ = _landmarks(X, F)
    return X, F, Xt, tri, bc, np.einsum("kj,kjd->kd", bc, Xt[F[tri]])


def test_identical_surfaces_stay_put():
    X, F = _sheet()
    tri, bc, y = _landmarks(X, F)
    res = _icp(X, F, X, F, tri, bc, y)
    np.testing.assert_allclose(res.deformed, X, atol=1e-9)
    assert res.matched.all() and res.distance.max() < 1e-9
    assert len(res.history) == len(STIFFNESS_SCHEDULE) and res.history[-1]["step"] < 1e-9
    # the closest points are the vertices themselves, in a triangle holding them
    np.testing.assert_allclose(
        np.einsum("kj,kjd->kd", res.barycentric, X[F[res.triangle]]), X, atol=1e-9
    )


def test_shifted_and_bent_target_is_reached_and_landmarks_follow():
    X, F, Xt, tri, bc, y = _bump_pair()
    X_in, Xt_in = X.copy(), Xt.copy()
    res = _icp(X, F, Xt, F, tri, bc, y)
    np.testing.assert_array_equal(X, X_in)  # inputs not mutated
    np.testing.assert_array_equal(Xt, Xt_in)
    assert res.distance.max() < 2e-3  # on the target
    # the motion is normal to the sheet: the sideways slide is a small fraction of the
    # bump's 0.1 lift (6.6e-3 with the default 6 iterations, 3.1e-3 with 3 per stage)
    np.testing.assert_allclose(res.deformed[:, :2], X[:, :2], atol=1e-2)
    res_slow = _icp(X, F, Xt, F, tri, bc, y, iterations=3)
    np.testing.assert_allclose(res_slow.deformed[:, :2], X[:, :2], atol=5e-3)
    lm = np.einsum("kj,kjd->kd", bc, res.deformed[F[tri]])
    np.testing.assert_allclose(lm, y, atol=5e-3)
    # zero weights: those vertices follow the smooth field only (still near the target)
    w = np.ones(len(X))
    w[: len(X) // 4] = 0.0
    res_w = _icp(X, F, Xt, F, tri, bc, y, weights=w)
    assert res_w.distance.max() < 2e-2


def test_repeated_stiffness_reuses_the_factorisation_through_cg():
    X, F, Xt, tri, bc, y = _bump_pair()
    res = _icp(X, F, Xt, F, tri, bc, y)
    cg = [h["cg_iterations"] for h in res.history]
    # the schedule's three supple iterations share one factorisation
    assert cg[:4] == [0.0] * 4 and all(c > 0 for c in cg[4:])
    # the same answer as factorising every iteration (stiffnesses apart by 1e-9)
    apart = [a * (1 + 1e-9 * i) for i, a in enumerate(STIFFNESS_SCHEDULE)]
    res_f = _icp(X, F, Xt, F, tri, bc, y, stiffness=apart)
    assert all(h["cg_iterations"] == 0 for h in res_f.history)
    np.testing.assert_allclose(res.deformed, res_f.deformed, atol=1e-8)


def test_rigid_motion_invariance():
    X, F = _sheet(2)
    Xt = X + np.array([0.0, 0.0, 0.03])
    tri, bc, y = _landmarks(X, F)
    res = _icp(X, F, Xt, F, tri, bc, y + [0.0, 0.0, 0.03])
    a = np.deg2rad(30.0)
    R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1.0]]) @ np.array(
        [[1.0, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]]
    )
    t = np.array([0.3, -0.2, 0.1])
    res_r = _icp(X @ R.T + t, F, Xt @ R.T + t, F, tri, bc, (y + [0.0, 0.0, 0.03]) @ R.T + t)
    np.testing.assert_allclose(res_r.deformed, res.deformed @ R.T + t, atol=1e-7)
    np.testing.assert_array_equal(res_r.matched, res.matched)


def test_validation():
    X, F = _sheet(1)
    tri, bc, y = _landmarks(X, F)
    with pytest.raises(ValueError, match="landmarks"):
        _icp(X, F, X, F, tri, bc[:2], y)
    with pytest.raises(ValueError, match="initial_displacement"):
        _icp(X, F, X, F, tri, bc, y, initial_displacement=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="weights"):
        _icp(X, F, X, F, tri, bc, y, weights=-np.ones(len(X)))
    with pytest.raises(ValueError, match="stiffness"):
        _icp(X, F, X, F, tri, bc, y, stiffness=(1e-3, 0.0))
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        _icp(X[:, :2], F, X, F, tri, bc, y)


def test_options_defaults_are_the_former_keyword_defaults():
    o = NonrigidICPOptions()
    assert tuple(o.stiffness) == STIFFNESS_SCHEDULE
    assert (o.iterations, o.landmark_weight, o.max_distance, o.min_normal_cosine) == (
        1,
        10.0,
        0.05,
        0.5,
    )
    X, F = _sheet(2)
    tri, bc, y = _landmarks(X, F)
    lm = ICPLandmarks(tri, bc, y)
    # omitted options are the defaults: the same deformation as NonrigidICPOptions()
    a = nonrigid_icp(X, F, X + [0.0, 0.0, 0.01], F, lm)
    b = nonrigid_icp(X, F, X + [0.0, 0.0, 0.01], F, lm, options=NonrigidICPOptions())
    np.testing.assert_array_equal(a.deformed, b.deformed)
    with pytest.raises(ValueError, match="positive"):
        nonrigid_icp(X, F, X, F, lm, options=NonrigidICPOptions(iterations=0))


def test_landmark_weights_and_schedule():
    X, F, Xt, tri, bc, y = _bump_pair()
    base = _icp(X, F, Xt, F, tri, bc, y)
    # all weights 1 and the constant schedule are the default
    same = nonrigid_icp(
        X,
        F,
        Xt,
        F,
        ICPLandmarks(tri, bc, y, np.ones(len(tri))),
        options=NonrigidICPOptions(landmark_schedule=[10.0] * len(STIFFNESS_SCHEDULE)),
    )
    np.testing.assert_allclose(same.deformed, base.deformed, atol=1e-10)
    # a wrong landmark (moved sideways by 0.1) drags the fit; weight 0 ignores it
    y_bad = y.copy()
    y_bad[0, :2] += 0.1
    dragged = _icp(X, F, Xt, F, tri, bc, y_bad)
    w = np.ones(len(tri))
    w[0] = 0.0
    free = nonrigid_icp(X, F, Xt, F, ICPLandmarks(tri, bc, y_bad, w))
    lm = lambda r: np.einsum("j,jd->d", bc[0], r.deformed[F[tri[0]]])  # noqa: E731
    assert np.linalg.norm(lm(free) - y[0]) < 0.2 * np.linalg.norm(lm(dragged) - y[0])


def test_landmark_retarget_lets_the_closest_points_correct_a_wrong_landmark():
    X, F, Xt, tri, bc, y = _bump_pair()
    y_bad = y.copy()
    y_bad[0, :2] += 0.05
    lm = lambda r: np.einsum("j,jd->d", bc[0], r.deformed[F[tri[0]]])  # noqa: E731
    pinned = _icp(X, F, Xt, F, tri, bc, y_bad)
    retarget = _icp(X, F, Xt, F, tri, bc, y_bad, landmark_retarget=1)
    assert np.linalg.norm(lm(retarget) - y[0]) < np.linalg.norm(lm(pinned) - y[0])
    # exact landmarks: retargeting keeps the fit on the target and the landmarks near theirs
    ok = _icp(X, F, Xt, F, tri, bc, y, landmark_retarget=2)
    assert ok.distance.max() < 2e-3
    np.testing.assert_allclose(np.einsum("kj,kjd->kd", bc, ok.deformed[F[tri]]), y, atol=1e-2)
    with pytest.raises(ValueError, match="landmark_retarget"):
        _icp(X, F, Xt, F, tri, bc, y, landmark_retarget=0)
    with pytest.raises(ValueError, match="landmark_schedule"):
        _icp(X, F, Xt, F, tri, bc, y, landmark_schedule=[1.0])
    with pytest.raises(ValueError, match="landmark weights"):
        nonrigid_icp(X, F, Xt, F, ICPLandmarks(tri, bc, y, -np.ones(len(tri))))


def _tiny_one_ring(scale):
    """A bumpy disk whose central vertex's one-ring is shrunk by ``scale`` (a clean mesh
    with a cluster of tiny triangles), and a gently bent copy as the target."""
    from tests.meshes import bumpy_disk

    V, F = bumpy_disk(16)
    V = V / np.linalg.norm(np.ptp(V, axis=0))
    c = int(np.argmin(np.linalg.norm(V[:, :2] - V[:, :2].mean(axis=0), axis=1)))
    ring = np.setdiff1d(np.unique(F[(F == c).any(axis=1)]), [c])
    X = V.copy()
    X[ring] = X[c] + scale * (V[ring] - V[c])
    T = V.copy()
    T[:, 2] += 0.02 * np.sin(3 * V[:, 0])
    tri = np.array([0, 5, 40])
    bc = np.full((3, 3), 1 / 3)
    return X, F, T, tri, bc, T[F[tri]].mean(axis=1)


@pytest.mark.parametrize("scale", [1e-5, 1e-7])
def test_a_tiny_one_ring_is_regularised_not_refused(scale):
    """Issue 27: the bi-Laplacian's 1/A_v at a vertex of 1e-10 of the mean area made the
    solve miss its residual test ("numerically singular") on a well-posed fit; the
    floored mass (and, if needed, a diagonal shift relative to the matrix's own) fits."""
    from conformorph.geometry.nonrigid_icp import ICP_DIAGONAL_SHIFTS

    X, F, T, tri, bc, y = _tiny_one_ring(scale)
    r = _icp(X, F, T, F, tri, bc, y)
    assert np.all(np.isfinite(r.deformed))
    assert r.history[-1]["rms_distance"] < 0.01
    assert {h["shift"] for h in r.history} <= {0.0, *ICP_DIAGONAL_SHIFTS}
    # away from the cluster the fit is that of the clean mesh
    clean = _icp(*_tiny_one_ring(1.0)[:1], F, T, F, tri, bc, y)
    moved = np.linalg.norm(r.deformed - X, axis=1)
    moved_clean = np.linalg.norm(clean.deformed - _tiny_one_ring(1.0)[0], axis=1)
    assert abs(np.median(moved) - np.median(moved_clean)) < 0.2 * np.median(moved_clean)


def test_symmetric_matching_spreads_the_source_over_the_target():
    """Closest points alone leave a flat source free to slide in its plane; with the
    symmetric term the target's own vertices pull it out over the whole target (a
    disk 4 % larger), which is what keeps features from sliding (issue 27)."""
    X, F = _sheet()
    Xt = X * [1.04, 1.04, 1.0]
    centre = int(np.argmin(np.linalg.norm(X, axis=1)))
    tri = np.array([int(np.flatnonzero((F == centre).any(axis=1))[0])])
    bc = np.eye(3)[[list(F[tri[0]]).index(centre)]]
    y = X[[centre]]
    radius = np.linalg.norm(X[:, :2], axis=1).max()
    plain = _icp(X, F, Xt, F, tri, bc, y)
    sym = _icp(X, F, Xt, F, tri, bc, y, symmetric=1.0)
    r_plain = np.linalg.norm(plain.deformed[:, :2], axis=1).max() / radius
    r_sym = np.linalg.norm(sym.deformed[:, :2], axis=1).max() / radius
    assert r_plain < 1.01 < 1.03 < r_sym < 1.045
    with pytest.raises(ValueError, match="symmetric"):
        _icp(X, F, Xt, F, tri, bc, y, symmetric=-1.0)


def test_vertex_pull_recovers_a_tangential_shift_closest_points_cannot_see():
    """A flat sheet and the same sheet with its vertices slid within the plane by a
    smooth bump (a third of an edge at most): the surfaces coincide, so closest points
    leave every vertex where it is; the mutual nearest target vertices (issue 27) carry
    each vertex most of the way to its own target vertex."""
    X, F = _sheet()
    h = float(np.mean(np.linalg.norm(X[F[:, 0]] - X[F[:, 1]], axis=1)))
    Xt = X.copy()
    Xt[:, 0] += 0.3 * h * np.exp(-np.sum((X[:, :2] - [0.3, 0.0]) ** 2, axis=1) / 0.05)
    corner = int(np.argmax(X[:, 0] + X[:, 1]))  # far from the bump: slid by ~0
    tri = np.array([int(np.flatnonzero((F == corner).any(axis=1))[0])])
    bc = np.eye(3)[[list(F[tri[0]]).index(corner)]]
    y = Xt[[corner]]
    before = np.linalg.norm(X - Xt, axis=1)
    plain = _icp(X, F, Xt, F, tri, bc, y)
    pulled = _icp(X, F, Xt, F, tri, bc, y, vertex_pull=0.5, vertex_pull_from=0)
    err_plain = np.linalg.norm(plain.deformed - Xt, axis=1)
    err_pulled = np.linalg.norm(pulled.deformed - Xt, axis=1)
    assert err_plain.mean() > 0.95 * before.mean()  # closest points: no tangential pull
    assert err_pulled.mean() < 0.2 * before.mean()  # measured 0.05
    assert err_pulled.max() < 0.2 * before.max()  # measured 0.08
    # the result's closest points are plain closest points (on the target plane)
    assert np.abs(pulled.closest[:, 2]).max() < 1e-12 and pulled.distance.max() < 1e-3 * h
    # a pull from a stage past the schedule changes nothing
    late = _icp(X, F, Xt, F, tri, bc, y, vertex_pull=0.5, vertex_pull_from=99)
    np.testing.assert_allclose(late.deformed, plain.deformed, atol=1e-12)
    for bad in ({"vertex_pull": 1.5}, {"vertex_pull": -0.1}, {"vertex_pull_from": -1}):
        with pytest.raises(ValueError, match="vertex_pull"):
            _icp(X, F, Xt, F, tri, bc, y, **bad)
