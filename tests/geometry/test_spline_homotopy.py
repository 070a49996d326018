import numpy as np
import pytest

from conformorph.geometry.spline_homotopy import SplineHomotopy, spline_homotopy


def test_hand_worked_natural_spline():
    # natural cubic spline through (0,0), (1,1), (2,0): S(0.5) = 11/16 (hand computation:
    # M1 = -3 from the moment equation 4 M1 = 6 (0 - 2·1 + 0), S = ... )
    t = np.array([0.0, 1.0, 2.0])
    y = np.array([0.0, 1.0, 0.0])
    assert spline_homotopy(t, y, 0.5) == pytest.approx(11 / 16)
    # second derivative zero at both ends
    S = SplineHomotopy(t, y)
    assert S(0.0, 2) == pytest.approx(0.0, abs=1e-12) and S(2.0, 2) == pytest.approx(0.0, abs=1e-12)


def test_keys_reproduced_vectorised_and_linear_path_exact():
    rng = np.random.default_rng(0)
    t = np.array([0.0, 0.7, 2.0, 2.5])
    vals = rng.normal(size=(4, 50, 3))
    S = SplineHomotopy(t, vals)
    np.testing.assert_allclose(S(t), vals, atol=1e-12)
    assert S(1.3).shape == (50, 3) and S(np.array([1.3, 1.4])).shape == (2, 50, 3)
    # per-vertex independence: evaluating a slice equals slicing the evaluation
    np.testing.assert_allclose(SplineHomotopy(t, vals[:, 7])(1.1), S(1.1)[7])
    # a path linear in t is reproduced exactly, also when extrapolating
    a, b = rng.normal(size=(2, 10))
    lin = a[None] + t[:, None] * b[None]
    te = np.array([-0.5, 0.3, 1.9, 3.0])
    np.testing.assert_allclose(
        SplineHomotopy(t, lin)(te), a[None] + te[:, None] * b[None], atol=1e-12
    )


def test_two_keys_give_straight_line_and_convergence():
    np.testing.assert_allclose(
        spline_homotopy([0.0, 2.0], np.array([1.0, 3.0]), [1.0, 3.0]), [2.0, 4.0]
    )
    # interpolating sin on refined key sets: error falls like h^4 (h^2 near natural ends; test interior)
    errs = []
    for n in (6, 12, 24):
        t = np.linspace(0, np.pi, n + 1)
        S = SplineHomotopy(t, np.sin(t))
        te = np.linspace(1.0, 2.0, 101)
        errs.append(np.abs(S(te) - np.sin(te)).max())
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 3.0), rates


def test_validation_and_no_mutation():
    t = np.array([0.0, 1.0])
    v = np.zeros((2, 3))
    t0, v0 = t.copy(), v.copy()
    spline_homotopy(t, v, 0.5)
    np.testing.assert_array_equal(t, t0)
    np.testing.assert_array_equal(v, v0)
    with pytest.raises(ValueError):
        SplineHomotopy(np.array([0.0, 0.0]), v)
    with pytest.raises(ValueError):
        SplineHomotopy(np.array([0.0]), v[:1])
    with pytest.raises(ValueError):
        SplineHomotopy(t, np.zeros((3, 2)))
    with pytest.raises(ValueError):
        SplineHomotopy(t, v, bc_type="periodic")  # type: ignore[arg-type]
