import numpy as np
import pytest
import scipy.sparse as sp

from conformorph.geometry import SingularSystemError, cotangent_laplacian, factorize
from tests.meshes import bumpy_disk


def test_spd_solve_matches_dense_and_reuses_factor():
    V, F = bumpy_disk(5)
    L = cotangent_laplacian(V, F) + sp.eye_array(len(V))
    fac = factorize(L)
    assert fac.backend in ("qdldl", "superlu")
    B = np.random.default_rng(0).normal(size=(len(V), 3))
    X = fac.solve(B)
    np.testing.assert_allclose(X, np.linalg.solve(L.toarray(), B), atol=1e-10)
    np.testing.assert_allclose(fac.solve(B[:, 0]), X[:, 0], atol=1e-12)


def test_indefinite_symmetric_matrix_is_solved_by_pivoting():
    A = sp.csc_array(np.array([[0.0, 1.0], [1.0, 0.0]]))
    fac = factorize(A, symmetric=True)
    np.testing.assert_allclose(fac.solve(np.array([2.0, 3.0])), [3.0, 2.0])


def test_singular_matrix_raises_instead_of_returning_nan():
    V, F = bumpy_disk(4)
    L = cotangent_laplacian(V, F)  # constant null space
    with pytest.raises(SingularSystemError):
        fac = factorize(L)
        fac.solve(np.random.default_rng(1).normal(size=len(V)))


def test_unsymmetric_and_bad_input():
    A = sp.csc_array(np.array([[2.0, 1.0], [0.0, 3.0]]))
    fac = factorize(A)
    assert fac.backend == "superlu"
    np.testing.assert_allclose(A @ fac.solve(np.array([1.0, 1.0])), [1.0, 1.0])
    with pytest.raises(ValueError, match="square"):
        factorize(sp.csc_array(np.ones((2, 3))))
    with pytest.raises(ValueError, match="rows"):
        fac.solve(np.ones(3))


def test_symmetric_systems_use_qdldl_the_measured_fastest_backend():
    # qdldl is a runtime dependency (pyproject): a missing install would silently
    # fall back to SuperLU and cost ~1.5x on the disk map (measured), so it must show here
    V, F = bumpy_disk(6)
    L = cotangent_laplacian(V, F)[1:, 1:]
    assert factorize(L, symmetric=True).backend == "qdldl"
    assert factorize(L + sp.eye_array(L.shape[0]) * 0, symmetric=False).backend == "superlu"


def test_precondition_is_the_solve_without_its_residual_check():
    n = 30
    A = sp.diags_array([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], offsets=[-1, 0, 1])
    fac = factorize(A, symmetric=True)
    b = np.random.default_rng(0).standard_normal((n, 3))
    np.testing.assert_array_equal(fac.precondition(b), fac.solve(b))
    np.testing.assert_array_equal(fac.precondition(b[:, 0]), fac.solve(b[:, 0]))
    with pytest.raises(ValueError, match="rows"):
        fac.precondition(b[:-1])


def test_symmetric_refactorization_reuses_the_pattern_and_falls_back():
    from conformorph.geometry import SymmetricRefactorization

    V, F = bumpy_disk(5)
    L = sp.csc_array(cotangent_laplacian(V, F) + sp.eye_array(len(V)))
    ref = SymmetricRefactorization()
    b = np.random.default_rng(2).normal(size=len(V))
    for scale in (1.0, 3.0, 0.5):  # same pattern, new numbers: each solve is exact
        A = sp.csc_array(scale * L + sp.diags_array(np.linspace(0, 1, len(V))))
        x = ref.factorize(A, sp.csc_array(sp.triu(A))).solve(b)
        np.testing.assert_allclose(x, np.linalg.solve(A.toarray(), b), atol=1e-10)
    # a changed pattern is refused, not silently mis-factorised
    with pytest.raises(ValueError, match="pattern"):
        small = sp.csc_array(sp.eye_array(len(V)))
        ref.factorize(small, small)
    # an indefinite matrix with a zero pivot goes to SuperLU, then the pattern is analysed anew
    Z = sp.csc_array(np.array([[0.0, 1.0], [1.0, 0.0]]))
    # upper triangle with both (zero) diagonal entries stored
    Zu = sp.csc_array(
        (np.array([0.0, 1.0, 0.0]), np.array([0, 0, 1]), np.array([0, 1, 3])), shape=(2, 2)
    )
    ref2 = SymmetricRefactorization()
    fac = ref2.factorize(Z, Zu)
    assert fac.backend == "superlu"
    np.testing.assert_allclose(fac.solve(np.array([2.0, 3.0])), [3.0, 2.0])
