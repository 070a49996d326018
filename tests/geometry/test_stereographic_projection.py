import numpy as np
import pytest

from conformorph.geometry.boundary_loop import boundary_loop
from conformorph.geometry.flipped_triangles import signed_areas_2d
from conformorph.geometry.stereographic_projection import (
    equator_rotation,
    hemisphere_to_disk,
    inverse_stereographic_projection,
    normalize_boundary_to_circle,
    stereographic_projection,
)
from tests.meshes import bumpy_disk, disk_grid, random_rotation, spherical_cap


def test_known_points_by_hand():
    P = np.array([[0.0, 0, 1], [1, 0, 0], [0, -1, 0], [0.6, 0, 0.8]])
    uv = stereographic_projection(P)
    # (x, y) / (1 + z): north pole -> 0, equator fixed, (0.6, 0, 0.8) -> 1/3
    np.testing.assert_allclose(uv, [[0, 0], [1, 0], [0, -1], [1 / 3, 0]], atol=1e-15)


def test_round_trip_and_conformality():
    rng = np.random.default_rng(1)
    uv = rng.uniform(-2, 2, size=(50, 2))
    P = inverse_stereographic_projection(uv)
    np.testing.assert_allclose(np.linalg.norm(P, axis=1), 1, atol=1e-14)
    np.testing.assert_allclose(stereographic_projection(P), uv, atol=1e-12)
    # conformal: the Jacobian of the inverse is a multiple of an isometry
    h = 1e-6
    for p in uv[:5]:
        d0 = inverse_stereographic_projection(
            (p + [h, 0])[None]
        ) - inverse_stereographic_projection((p - [h, 0])[None])
        d1 = inverse_stereographic_projection(
            (p + [0, h])[None]
        ) - inverse_stereographic_projection((p - [0, h])[None])
        assert abs(np.vdot(d0, d1)) < 1e-9 * np.linalg.norm(d0) ** 2
        assert abs(np.linalg.norm(d0) - np.linalg.norm(d1)) < 1e-8 * np.linalg.norm(d0)


def test_south_pole_raises():
    with pytest.raises(ValueError, match="south pole"):
        stereographic_projection(np.array([[0.0, 0, -1]]))
    with pytest.raises(ValueError):
        stereographic_projection(np.zeros((3, 2)))


def test_equator_rotation_recovers_a_tilted_cap():
    V, F = spherical_cap(6, height=1.0)  # a hemisphere: boundary on the equator
    R0 = random_rotation(3)
    P = V @ R0.T
    b = boundary_loop(F)
    R = equator_rotation(P[b], P)
    Q = P @ R.T
    assert np.abs(Q[b, 2]).max() < 1e-12
    assert Q[:, 2].mean() > 0
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(R) > 0


def test_hemisphere_to_disk_is_ccw_and_on_circle():
    V, F = spherical_cap(6, height=1.0)
    b = boundary_loop(F)
    for R0 in (np.eye(3), random_rotation(5), np.diag([1.0, -1.0, -1.0])):
        uv = hemisphere_to_disk(V @ R0.T, F, b)
        assert np.all(signed_areas_2d(uv, F) > 0)
        np.testing.assert_allclose(np.hypot(*uv[b].T), 1, atol=1e-12)


def test_normalize_boundary_keeps_a_harmonic_map_and_fixes_the_circle():
    V, F = bumpy_disk(6)
    b = boundary_loop(F)
    flat = V[:, :2].copy()  # disk_grid's boundary is on the unit circle: a harmonic-ish start
    uv = normalize_boundary_to_circle(V, F, flat, b)
    np.testing.assert_allclose(np.hypot(*uv[b].T), 1, atol=1e-15)
    # applied twice, the result does not change (a harmonic map is its own extension)
    np.testing.assert_allclose(normalize_boundary_to_circle(V, F, uv, b), uv, atol=1e-12)
    # a perturbed boundary radius is snapped, the angles kept
    bumped = uv.copy()
    bumped[b] *= 1.01 + 0.01 * np.sin(np.arange(b.size))[:, None]
    out = normalize_boundary_to_circle(V, F, bumped, b)
    np.testing.assert_allclose(out, uv, atol=1e-12)


def test_inputs_not_mutated():
    V, F = disk_grid(4)
    b = boundary_loop(F)
    uv = 1.1 * V[:, :2]
    copies = [x.copy() for x in (V, F, uv)]
    normalize_boundary_to_circle(V, F, uv, b)
    hemisphere_to_disk(inverse_stereographic_projection(uv), F, b)
    for x, y in zip((V, F, uv), copies, strict=True):
        np.testing.assert_array_equal(x, y)
