import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.disk_registration import register_disk_landmarks
from conformorph.geometry.mesh_errors import FoldedMapError
from conformorph.geometry.mobius_registration import MobiusTransform


def _setup(shift=0.02, seed=0):
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(0, 0.5, 20))
    a = rng.uniform(0, 2 * np.pi, 20)
    P = np.c_[r * np.cos(a), r * np.sin(a)]
    Q = MobiusTransform(0.1 + 0.05j, 0.2).apply(P) + rng.normal(0, shift, P.shape)
    uv, F = refine_disk_mesh(*landmark_disk_mesh(P, n_boundary=16), 2)
    return P, Q, uv, F


def test_mt_and_dmt_errors_and_bijectivity():
    P, Q, uv, F = _setup()
    mt = register_disk_landmarks(P, Q, uv, F, method="mt")
    dmt = register_disk_landmarks(P, Q, uv, F, method="dmt")
    assert mt.method == "mt" and mt.deformation is None
    assert dmt.method == "dmt" and dmt.fallback is None
    assert dmt.error_disk < 1e-10 < mt.error_disk  # exact thin-plate interpolation
    assert dmt.fold is not None and dmt.fold.is_bijective
    np.testing.assert_allclose(dmt.apply(P), Q, atol=1e-10)
    # the check nodes' images are kept, equal to applying the returned map
    for reg in (mt, dmt):
        assert reg.check_image is not None
        np.testing.assert_allclose(reg.check_image, reg.apply(uv), atol=1e-14)


def test_large_displacement_is_split_into_steps_not_folded():
    P, Q, uv, F = _setup()
    Q2 = P.copy()
    Q2[0] = P[0] + (P[1] - P[0]) * 1.6  # landmark 0 jumps past landmark 1: one step folds
    dmt = register_disk_landmarks(P, Q2, uv, F, method="dmt")
    assert dmt.attempts[0]["n_folded"] > 0
    assert dmt.fold is not None and dmt.fold.is_bijective
    assert dmt.fallback in ("stepwise", "regularized", "mt")
    assert len(dmt.attempts) >= 2


def test_impossible_registration_falls_back_or_raises():
    # two landmarks swapped: no orientation-preserving map exists that is exact
    P, Q, uv, F = _setup(shift=0.0)
    Q = Q.copy()
    Q[[0, 1]] = Q[[1, 0]]
    res = register_disk_landmarks(P, Q, uv, F, method="dmt", max_steps=4)
    assert res.fold is not None and res.fold.is_bijective  # whatever is returned does not fold
    assert res.check_image is not None
    np.testing.assert_allclose(res.check_image, res.apply(uv), atol=1e-14)
    assert res.fallback is not None
    with pytest.raises(FoldedMapError):
        register_disk_landmarks(
            P, Q, uv, F, method="dmt", max_steps=2, fold_regularizations=(), on_fold="raise"
        )


def test_validation():
    P, Q, uv, F = _setup()
    with pytest.raises(ValueError):
        register_disk_landmarks(P, Q, uv, F, method="tps")  # type: ignore[arg-type]
