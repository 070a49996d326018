"""Tests of conformorph.geometry.green_lagrange_strain (eq. 1–3 of Yan, Hu and Martin 2004)."""

import numpy as np
import pytest

from conformorph.geometry.green_lagrange_strain import (
    green_lagrange_strain,
    interpolate_strain,
    shape_function_gradients,
    signed_areas,
)
from conformorph.geometry.mesh_errors import NotTrianglesError, ZeroAreaFaceError

TRI = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
F1 = np.array([[0, 1, 2]])


def _grid(k: int) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.meshgrid(np.linspace(0, 1, k + 1), np.linspace(0, 1, k + 1))
    V = np.c_[x.ravel(), y.ravel()]
    F = []
    for j in range(k):
        for i in range(k):
            a = j * (k + 1) + i
            F += [[a, a + 1, a + k + 2], [a, a + k + 2, a + k + 1]]
    return V, np.array(F, dtype=np.int64)


def test_hand_worked_stretch_and_shear():
    # x' = 2x: ε_x = (4 − 1)/2 = 1.5, ε_y = 0, γ = 0
    V = TRI * [2.0, 1.0]
    assert green_lagrange_strain(TRI, V, F1)[0] == pytest.approx([1.5, 0.0, 0.0])
    # simple shear x' = x + s y: J = [[1, s], [0, 1]]: ε_x = 0, ε_y = s²/2, γ = s
    s = 0.3
    V = TRI + np.c_[s * TRI[:, 1], 0 * TRI[:, 1]]
    assert green_lagrange_strain(TRI, V, F1)[0] == pytest.approx([0.0, s * s / 2, s])


def test_shape_function_gradients_sum_to_zero_and_reproduce_linear_fields():
    V, F = _grid(4)
    dN, area = shape_function_gradients(V, F)
    assert np.allclose(dN.sum(axis=1), 0.0)
    assert area.sum() == pytest.approx(1.0)
    # gradient of the linear field u = 3x − 2y is exact on every triangle
    u = 3 * V[:, 0] - 2 * V[:, 1]
    g = np.einsum("fk,fka->fa", u[F], dN)
    assert np.allclose(g, [3.0, -2.0])


def test_rigid_motion_gives_zero_strain_and_strain_is_rotation_invariant_in_V():
    V, F = _grid(3)
    rng = np.random.default_rng(0)
    W = V + 0.05 * rng.standard_normal(V.shape)
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    assert np.allclose(green_lagrange_strain(V, V @ R.T + [5, -3], F), 0.0, atol=1e-13)
    e1 = green_lagrange_strain(V, W, F)
    e2 = green_lagrange_strain(V, W @ R.T + [1, 2], F)
    assert np.allclose(e1, e2, atol=1e-12)


@pytest.mark.parametrize("scale", [1e-8, 1.0, 1e8])
def test_strain_is_scale_free(scale):
    V, F = _grid(3)
    W = V * [1.2, 0.9] + [0.1, 0]
    assert np.allclose(
        green_lagrange_strain(scale * V, scale * W, F), green_lagrange_strain(V, W, F)
    )


def test_face_reordering_permutes_strain():
    V, F = _grid(3)
    W = V**2 + V
    perm = np.random.default_rng(1).permutation(F.shape[0])
    rolled = np.roll(F[perm], 1, axis=1)  # same orientation, other starting corner
    assert np.allclose(green_lagrange_strain(V, W, rolled), green_lagrange_strain(V, W, F)[perm])


def test_interpolation_end_points_and_monotonicity():
    rng = np.random.default_rng(2)
    J = np.eye(2) + 0.4 * rng.standard_normal((50, 2, 2))
    # orientation-preserving deformation gradients: negating a whole 2 × 2 matrix keeps
    # its determinant, so mirror one column of those with det J < 0 instead
    J[np.linalg.det(J) < 0, :, 0] *= -1
    assert np.all(np.linalg.det(J) > 0)
    eps = np.c_[
        0.5 * (np.sum(J[:, :, 0] ** 2, 1) - 1),
        0.5 * (np.sum(J[:, :, 1] ** 2, 1) - 1),
        np.sum(J[:, :, 0] * J[:, :, 1], 1),
    ]
    for scheme in ("modified", "linear"):
        assert np.allclose(interpolate_strain(eps, 0.0, scheme=scheme), 0.0)
        assert np.allclose(interpolate_strain(eps, 1.0, scheme=scheme), eps)
        seq = np.array([interpolate_strain(eps, t, scheme=scheme) for t in np.linspace(0, 1, 21)])
        d = np.diff(seq, axis=0)
        assert np.all(np.all(d >= -1e-15, axis=0) | np.all(d <= 1e-15, axis=0))


def test_modified_scheme_makes_stretch_linear_in_time():
    eps = np.array([[1.5, -0.375, 0.0]])  # stretches 2 and 0.5
    for t in (0.25, 0.5, 0.8):
        e = interpolate_strain(eps, t)
        assert np.sqrt(1 + 2 * e[0, 0]) == pytest.approx(1 + t)
        assert np.sqrt(1 + 2 * e[0, 1]) == pytest.approx(1 - 0.5 * t)


def test_modified_scheme_shear_is_tan_of_t_arctan_gamma_hand_worked():
    # eq. (3): γ_t = tan(t · arctan γ). γ = √3 (60°): t = 1/2 gives tan 30° = 1/√3,
    # t = 1/3 gives tan 20°; γ = −1 (−45°) at t = 1/2 gives −tan 22.5° = 1 − √2.
    # The stretch parts are independent: ε_x = 1.5 (stretch 2) at t = 1/2 is stretch
    # 1.5, i.e. ε_x = (1.5² − 1)/2 = 0.625; ε_y = 0 stays 0.
    eps = np.array([[1.5, 0.0, np.sqrt(3.0)], [0.0, 0.0, -1.0]])
    half = interpolate_strain(eps, 0.5)
    np.testing.assert_allclose(half, [[0.625, 0.0, 1 / np.sqrt(3.0)], [0.0, 0.0, 1 - np.sqrt(2.0)]])
    third = interpolate_strain(eps, 1 / 3)
    assert third[0, 2] == pytest.approx(np.tan(np.pi / 9))
    assert third[1, 2] == pytest.approx(-np.tan(np.pi / 12))
    # the shear is not linear in t (eq. 2 would give γ/2 = 0.866 and −0.5)
    assert half[0, 2] != pytest.approx(np.sqrt(3.0) / 2)
    assert interpolate_strain(eps, 0.5, scheme="linear")[:, 2] == pytest.approx(
        [np.sqrt(3) / 2, -0.5]
    )


def test_validation_errors():
    with pytest.raises(NotTrianglesError):
        green_lagrange_strain(np.zeros((3, 3)), np.zeros((3, 3)), F1)
    with pytest.raises(ZeroAreaFaceError):
        shape_function_gradients(TRI[[0, 2, 1]], F1)  # clockwise
    with pytest.raises(ZeroAreaFaceError):
        shape_function_gradients(np.array([[0.0, 0], [1, 0], [2, 0]]), F1)
    with pytest.raises(ValueError):
        interpolate_strain(np.zeros((2, 3)), 1.5)
    with pytest.raises(ValueError):
        interpolate_strain(np.zeros((2, 3)), 0.5, scheme="cubic")  # type: ignore[arg-type]


def test_inputs_not_mutated():
    V, F = _grid(2)
    W = V * 1.1
    copies = V.copy(), W.copy(), F.copy()
    green_lagrange_strain(V, W, F)
    signed_areas(V, F)
    eps = np.ones((3, 3)) * 0.1
    e0 = eps.copy()
    interpolate_strain(eps, 0.3)
    assert (
        np.array_equal(V, copies[0])
        and np.array_equal(W, copies[1])
        and np.array_equal(F, copies[2])
    )
    assert np.array_equal(eps, e0)


def test_principal_scheme_hand_worked_and_frame_invariant():
    # pure x stretch by 3: the principal frame is the x/y frame, stretch 1 + 2t
    e = np.array([[4.0, 0.0, 0.0]])
    np.testing.assert_allclose(interpolate_strain(e, 0.5, scheme="principal"), [[1.5, 0, 0]])
    np.testing.assert_allclose(
        interpolate_strain(e, 0.5, scheme="principal"), interpolate_strain(e, 0.5)
    )
    # the same stretch along the diagonal: U = R diag(3, 1) Rᵀ, U_t = R diag(2, 1) Rᵀ at t = 1/2
    c = s = np.sqrt(0.5)
    R = np.array([[c, -s], [s, c]])

    def strain_of(U):
        C = U.T @ U
        return np.array([[0.5 * (C[0, 0] - 1), 0.5 * (C[1, 1] - 1), C[0, 1]]])

    E = strain_of(R @ np.diag([3.0, 1.0]) @ R.T)
    np.testing.assert_allclose(
        interpolate_strain(E, 0.5, scheme="principal"),
        strain_of(R @ np.diag([2.0, 1.0]) @ R.T),
        atol=1e-14,
    )
    # eq. (3) in the fixed frame gives a different state here (it is frame dependent)
    assert not np.allclose(interpolate_strain(E, 0.5), strain_of(R @ np.diag([2.0, 1.0]) @ R.T))


def test_principal_scheme_end_points_and_positive_definite():
    rng = np.random.default_rng(3)
    J = np.eye(2) + 0.8 * rng.standard_normal((200, 2, 2))
    J[np.linalg.det(J) < 0, :, 0] *= -1  # mirror one column: det J > 0 for every gradient
    assert np.all(np.linalg.det(J) > 0)
    eps = np.c_[
        0.5 * (np.sum(J[:, :, 0] ** 2, 1) - 1),
        0.5 * (np.sum(J[:, :, 1] ** 2, 1) - 1),
        np.sum(J[:, :, 0] * J[:, :, 1], 1),
    ]
    assert np.allclose(interpolate_strain(eps, 0.0, scheme="principal"), 0.0)
    assert np.allclose(interpolate_strain(eps, 1.0, scheme="principal"), eps)
    for t in np.linspace(0, 1, 11):
        e = interpolate_strain(eps, float(t), scheme="principal")
        det_C = (1 + 2 * e[:, 0]) * (1 + 2 * e[:, 1]) - e[:, 2] ** 2
        assert np.all(det_C > 0)
