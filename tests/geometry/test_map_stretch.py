"""Tests of conformorph.geometry.map_stretch (principal stretches of a map between compatible meshes)."""

import numpy as np
import pytest

from conformorph.geometry.map_stretch import map_stretch, principal_stretches

TRI = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
TWO = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
F2 = np.array([[0, 1, 2], [0, 2, 3]])


def rot(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


# ---- (a) hand-worked cases
def test_axis_stretch_and_rotation():
    # x stretched 3-fold, y halved, then rotated: σ = 3, 0.5 whatever the rotation
    T = (TRI * [3.0, 0.5]) @ rot(0.7).T + [5.0, -2.0]
    s = principal_stretches(TRI, T, np.array([[0, 1, 2]]))
    assert np.allclose(s, [[3.0, 0.5]], atol=1e-12)
    m = map_stretch(TRI, T, np.array([[0, 1, 2]]))
    assert m.max_stretch == pytest.approx(3.0) and m.min_stretch == pytest.approx(0.5)
    assert m.max_anisotropy == pytest.approx(6.0) and m.worst_triangle == 0


def test_shear_has_golden_ratio_stretches():
    # J = [[1, 1], [0, 1]]: JᵀJ = [[1, 1], [1, 2]], eigenvalues (3 ± √5)/2 = φ², φ⁻²
    phi = (1.0 + np.sqrt(5.0)) / 2.0
    T = TRI @ np.array([[1.0, 1.0], [0.0, 1.0]]).T
    s = principal_stretches(TRI, T, np.array([[0, 1, 2]]))
    assert np.allclose(s, [[phi, 1.0 / phi]], atol=1e-12)


def test_worst_triangle_is_the_most_anisotropic():
    # the square's second triangle (0, 2, 3) keeps its shape, the first is squeezed:
    # moving vertex 1 to (1, 0.9) maps triangle (0, 1, 2) by J = [[1, 0], [0.9, 0.1]]
    T = TWO.copy()
    T[1] = [1.0, 0.9]
    m = map_stretch(TWO, T, F2)
    s = principal_stretches(TWO, T, F2)
    assert np.allclose(s[1], [1.0, 1.0])
    J = np.array([[1.0, 0.0], [0.9, 0.1]])
    assert np.allclose(s[0], np.linalg.svd(J, compute_uv=False), atol=1e-12)
    assert m.worst_triangle == 0
    assert m.max_anisotropy == pytest.approx(s[0, 0] / s[0, 1])


def test_degenerate_target_triangle_is_infinitely_anisotropic():
    T = TRI.copy()
    T[2] = [2.0, 0.0]  # collinear
    m = map_stretch(TRI, T, np.array([[0, 1, 2]]))
    assert m.min_stretch == 0.0 and m.max_anisotropy == np.inf


# ---- (b) invariants
def test_similarity_has_anisotropy_one():
    rng = np.random.default_rng(3)
    V = rng.random((30, 2))
    from scipy.spatial import Delaunay

    F = Delaunay(V).simplices.astype(np.int64)
    a = (V[F[:, 1]] - V[F[:, 0]])[:, 0] * (V[F[:, 2]] - V[F[:, 0]])[:, 1]
    b = (V[F[:, 1]] - V[F[:, 0]])[:, 1] * (V[F[:, 2]] - V[F[:, 0]])[:, 0]
    F[a - b < 0] = F[a - b < 0][:, [0, 2, 1]]
    m = map_stretch(V, 2.5 * V @ rot(1.1).T, F)
    assert m.max_anisotropy == pytest.approx(1.0, abs=1e-9)
    assert m.max_stretch == pytest.approx(2.5) and m.min_stretch == pytest.approx(2.5)


# ---- (c) scale of the source and target together leaves the stretches unchanged
@pytest.mark.parametrize("scale", [1e-8, 1e8])
def test_common_scale_invariance(scale):
    T = TRI * [3.0, 0.5]
    s = principal_stretches(scale * TRI, scale * T, np.array([[0, 1, 2]]))
    assert np.allclose(s, [[3.0, 0.5]], rtol=1e-9)


# ---- validation and (e) inputs not mutated
def test_mismatched_shapes_are_refused():
    with pytest.raises(ValueError, match="shape"):
        principal_stretches(TRI, TRI[:2], np.array([[0, 1, 2]]))


def test_inputs_not_mutated():
    T = TRI * [3.0, 0.5]
    c = TRI.copy(), T.copy()
    map_stretch(TRI, T, np.array([[0, 1, 2]]))
    assert np.array_equal(TRI, c[0]) and np.array_equal(T, c[1])
