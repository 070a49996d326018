import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.point_location import PointLocator, locate_points


def _disk(levels=3, seed=0):
    rng = np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(0, 0.8, 12))
    a = rng.uniform(0, 2 * np.pi, 12)
    uv, F = landmark_disk_mesh(np.c_[r * np.cos(a), r * np.sin(a)], n_boundary=12)
    return refine_disk_mesh(uv, F, levels)


def test_hand_worked_triangle():
    uv = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
    loc = locate_points(uv, np.array([[0, 1, 2]]), np.array([[0.5, 1.0], [0.0, 0.0]]))
    np.testing.assert_allclose(loc.barycentric, [[0.25, 0.25, 0.5], [1.0, 0.0, 0.0]], atol=1e-15)
    assert loc.triangle.tolist() == [0, 0]
    assert loc.inside.all()


def test_points_reproduced_and_inside():
    uv, F = _disk()
    rng = np.random.default_rng(1)
    r = np.sqrt(rng.uniform(0, 0.9, 5000))
    a = rng.uniform(0, 2 * np.pi, 5000)
    pts = np.c_[r * np.cos(a), r * np.sin(a)]
    loc = PointLocator(uv, F).locate(pts)
    assert loc.inside.all()
    np.testing.assert_allclose(loc.interpolate(F, uv), pts, atol=1e-12)
    assert (loc.barycentric >= 0).all()
    np.testing.assert_allclose(loc.barycentric.sum(axis=1), 1.0)
    # the chosen triangle really contains the point (brute-force check on a sample)
    c = uv[F[loc.triangle[:50]]]
    np.testing.assert_allclose(np.einsum("pj,pjk->pk", loc.barycentric[:50], c), pts[:50])


def test_outside_points_snap_to_nearest_point():
    uv, F = _disk(2)
    pts = np.array([[1.5, 0.0], [0.0, -3.0]])
    loc = locate_points(uv, F, pts)
    snapped = loc.interpolate(F, uv)
    assert np.all(loc.distance > 0)
    np.testing.assert_allclose(np.linalg.norm(snapped - pts, axis=1), loc.distance)
    # nearest boundary point of the inscribed polygon: within the polygon's sagitta of the circle
    np.testing.assert_allclose(np.linalg.norm(snapped, axis=1), 1.0, atol=0.02)


def test_vertex_reordering_invariance():
    uv, F = _disk(2)
    perm = np.random.default_rng(2).permutation(uv.shape[0])
    inv = np.argsort(perm)
    uv2, F2 = uv[perm], inv[F]
    pts = np.random.default_rng(3).uniform(-0.6, 0.6, (300, 2))
    f1 = locate_points(uv, F, pts).interpolate(F, uv**2)
    f2 = locate_points(uv2, F2, pts).interpolate(F2, uv2**2)
    np.testing.assert_allclose(f1, f2, atol=1e-12)


def test_linear_functions_interpolated_exactly_and_convergence():
    # barycentric interpolation reproduces linear functions; error on a quadratic falls as h²
    pts = np.random.default_rng(4).uniform(-0.5, 0.5, (2000, 2))
    errs = []
    for lv in (2, 3, 4):
        uv, F = _disk(lv)
        loc = locate_points(uv, F, pts)
        lin = loc.interpolate(F, 3 * uv[:, 0] - uv[:, 1] + 1)
        np.testing.assert_allclose(lin, 3 * pts[:, 0] - pts[:, 1] + 1, atol=1e-12)
        quad = loc.interpolate(F, uv[:, 0] ** 2)
        errs.append(np.abs(quad - pts[:, 0] ** 2).max())
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 1.7), rates


def test_inputs_not_mutated_and_errors():
    uv, F = _disk(1)
    uv0, F0 = uv.copy(), F.copy()
    pts = np.zeros((3, 2))
    p0 = pts.copy()
    locate_points(uv, F, pts)
    np.testing.assert_array_equal(uv, uv0)
    np.testing.assert_array_equal(F, F0)
    np.testing.assert_array_equal(pts, p0)
    with pytest.raises(ValueError):
        locate_points(uv, F, np.zeros((3, 3)))
    with pytest.raises(ValueError):
        locate_points(uv, F + uv.shape[0], pts)
    with pytest.raises(ValueError):
        locate_points(uv, F, np.array([[np.nan, 0.0]]))


# cases carried over from the former geometry.locate_points (merged into this module)
_SQ_V = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
_SQ_F = np.array([[0, 1, 2], [0, 2, 3]])


def test_square_hand_worked_and_outside_point_snapped():
    loc = locate_points(_SQ_V, _SQ_F, np.array([[0.75, 0.25], [0.25, 0.75], [2.0, 0.0]]))
    assert loc.triangle[:2].tolist() == [0, 1]
    np.testing.assert_allclose(loc.barycentric[0], [0.25, 0.5, 0.25])
    assert loc.inside.tolist() == [True, True, False]
    assert loc.distance[2] == pytest.approx(1.0)  # nearest point (1, 0)
    np.testing.assert_allclose(loc.interpolate(_SQ_F, _SQ_V)[2], [1.0, 0.0])


def test_vertices_and_edges_reproduced():
    rng = np.random.default_rng(0)
    P = np.vstack([rng.random((50, 2)), _SQ_V, [[0.5, 0.5], [0.5, 0.0]]])
    loc = locate_points(_SQ_V, _SQ_F, P)
    assert loc.inside.all()
    np.testing.assert_allclose(loc.interpolate(_SQ_F, _SQ_V), P, atol=1e-14)
    assert np.all(loc.barycentric >= 0)


def test_scale_invariance_and_no_mutation():
    P = np.array([[0.3, 0.1], [0.9, 0.95]])
    c = _SQ_V.copy(), _SQ_F.copy(), P.copy()
    a = locate_points(_SQ_V, _SQ_F, P)
    b = locate_points(1e-8 * _SQ_V, _SQ_F, 1e-8 * P)
    assert np.array_equal(a.triangle, b.triangle)
    np.testing.assert_allclose(a.barycentric, b.barycentric)
    assert np.array_equal(_SQ_V, c[0]) and np.array_equal(_SQ_F, c[1]) and np.array_equal(P, c[2])
