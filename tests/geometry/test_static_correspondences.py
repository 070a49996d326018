import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.static_correspondences import (
    StaticCorrespondenceOptions,
    farthest_point_samples,
    static_correspondences,
)


def _sheet(bump=0.0, levels=3):
    uv, F = refine_disk_mesh(*landmark_disk_mesh(np.array([[0.0, 0.0]]), n_boundary=12), levels)
    z = bump * np.exp(-(((uv[:, 0] - 0.4) / 0.15) ** 2 + (uv[:, 1] / 0.15) ** 2))
    return uv, np.c_[uv, z], F


def test_farthest_point_samples_hand_worked():
    X = np.array([[0.0, 0], [1, 0], [0.1, 0], [0.5, 0]])
    assert farthest_point_samples(X, 3).tolist() == [0, 1, 3]
    assert farthest_point_samples(X, 2, candidates=np.array([2, 3])).tolist() == [2, 3]
    assert farthest_point_samples(X, 0).size == 0
    assert farthest_point_samples(X, 10).tolist() == [0, 1, 3, 2]  # k > n: every point once


def test_farthest_point_samples_invariants():
    rng = np.random.default_rng(3)
    X = rng.standard_normal((300, 3))
    cand = np.sort(rng.choice(300, 200, replace=False))
    ids = farthest_point_samples(X, 50, candidates=cand)
    assert ids.size == 50 and np.unique(ids).size == 50 and np.isin(ids, cand).all()
    # each pick is the candidate farthest from those chosen before it
    for i in range(1, 50):
        d = np.min(np.linalg.norm(X[cand][:, None] - X[ids[:i]][None], axis=2), axis=1)
        assert np.isclose(np.linalg.norm(X[ids[i]] - X[ids[:i]], axis=1).min(), d.max())
    # a rigid motion changes nothing
    R, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    assert np.array_equal(farthest_point_samples(X @ R.T + 5.0, 50, candidates=cand), ids)


def test_static_part_accepted_moving_part_rejected():
    uv, X0, F = _sheet(0.0)
    _, X1, _ = _sheet(0.3)  # a bump rises at (0.4, 0): that part "moves"
    samp = farthest_point_samples(
        X0, 80, candidates=np.flatnonzero(np.linalg.norm(uv, axis=1) < 0.9)
    )
    res = static_correspondences(
        uv[samp],
        X0[samp],
        uv[samp],
        X1,
        F,
        uv,
        StaticCorrespondenceOptions(tol=1e-3, max_disk_offset=0.05),
    )
    moving = np.linalg.norm(uv[samp] - [0.4, 0.0], axis=1) < 0.2
    assert not res.accepted[moving].any()
    assert res.accepted[~moving & (np.linalg.norm(uv[samp] - [0.4, 0.0], axis=1) > 0.5)].all()
    # static samples correspond to themselves (up to the bump's far tails)
    np.testing.assert_allclose(res.target_uv, res.source_uv, atol=1e-4)


def test_disk_consistency_and_separation():
    uv, X0, F = _sheet(0.0)
    samp = np.arange(0, 40)
    far = static_correspondences(
        uv[samp],
        X0[samp],
        uv[samp] + 0.5,
        X0,
        F,
        uv,
        StaticCorrespondenceOptions(tol=1e-3, max_disk_offset=0.05),
    )
    assert not far.accepted.any()
    sep = static_correspondences(
        uv[samp],
        X0[samp],
        uv[samp],
        X0,
        F,
        uv,
        StaticCorrespondenceOptions(tol=1e-3, max_disk_offset=0.05, min_separation=0.3),
    )
    P = sep.source_uv
    d = np.linalg.norm(P[:, None] - P[None], axis=2) + np.eye(len(P))
    assert d.min() >= 0.3 and 0 < len(P) < len(samp)
    with pytest.raises(ValueError):
        static_correspondences(
            uv[samp],
            X0[samp],
            uv[samp],
            X0,
            F,
            uv,
            StaticCorrespondenceOptions(tol=0.0, max_disk_offset=0.1),
        )


def test_options_need_tol_and_offset_and_default_to_no_separation():
    o = StaticCorrespondenceOptions(tol=1e-3, max_disk_offset=0.05)
    assert o.min_separation == 0.0
    with pytest.raises(TypeError):
        StaticCorrespondenceOptions(tol=1e-3)  # type: ignore[call-arg]
