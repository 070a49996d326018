import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh
from conformorph.geometry.surface_distance import (
    SurfaceDistance,
    _closest_point_on_triangles,
    surface_to_surface_error,
)


def _sheet(levels=3):
    uv, F = refine_disk_mesh(*landmark_disk_mesh(np.array([[0.1, 0.1]]), n_boundary=12), levels)
    return np.c_[uv, np.zeros(len(uv))], F


def test_hand_worked_point_triangle_regions():
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    P = np.array(
        [[0.2, 0.2, 3.0], [-1.0, -1.0, 0.0], [2.0, -1.0, 0.0], [0.5, -1.0, 1.0], [1.0, 1.0, 0.0]]
    )
    y = _closest_point_on_triangles(P, a, b, c)
    np.testing.assert_allclose(
        y, [[0.2, 0.2, 0], [0, 0, 0], [1, 0, 0], [0.5, 0, 0], [0.5, 0.5, 0]], atol=1e-15
    )


def test_against_dense_sampling():
    rng = np.random.default_rng(0)
    a, b, c = rng.normal(size=(3, 3))
    P = rng.normal(size=(50, 3))
    y = _closest_point_on_triangles(P, a, b, c)
    u = rng.random((200000, 2))
    m = u.sum(1) > 1
    u[m] = 1 - u[m]
    S = a + u[:, :1] * (b - a) + u[:, 1:] * (c - a)
    d_dense = np.min(np.linalg.norm(S[None] - P[:, None], axis=2), axis=1)
    d = np.linalg.norm(y - P, axis=1)
    assert np.all(d <= d_dense + 1e-12)
    assert np.all(d_dense - d < 0.02)


def test_offset_sheet_distance_and_invariance():
    V, F = _sheet()
    sd = SurfaceDistance(V, F)
    Q = V[:40] * 0.9 + [0, 0, 0.05]
    cp, d = sd.closest_points(Q)
    np.testing.assert_allclose(d, 0.05, atol=1e-12)
    np.testing.assert_allclose(cp[:, 2], 0, atol=1e-15)
    e = surface_to_surface_error(V + [0, 0, 0.01], F, V, F)
    diag = np.linalg.norm(V.max(0) - V.min(0))
    assert abs(e["L2"] - 0.01 / diag) < 1e-12 and abs(e["Linf"] - 0.01 / diag) < 1e-12
    # translation and scale of both surfaces together leave the relative error unchanged
    e2 = surface_to_surface_error(1e3 * (V + [0, 0, 0.01]) + 5.0, F, 1e3 * V + 5.0, F)
    assert abs(e2["L2"] - e["L2"]) < 1e-9
    # a coarse mesh lies on its refinement (whose boundary bulges out onto the circle)
    V2, F2 = _sheet(4)
    assert surface_to_surface_error(V, F, V2, F2)["L2_forward"] < 1e-12
    assert surface_to_surface_error(V2, F2, V, F)["L2_forward"] > 1e-6


def test_inputs_not_mutated():
    V, F = _sheet(2)
    V0, F0 = V.copy(), F.copy()
    Q = V.copy()
    SurfaceDistance(V, F).closest_points(Q)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)


def test_projected_barycentrics_by_hand():
    from conformorph.geometry.surface_distance import projected_barycentrics

    tri = np.array([[[0.0, 0, 0], [2, 0, 0], [0, 2, 0]]] * 4)
    pts = np.array([[0.5, 0.5, 3.0], [2.0, 0, 0], [-1.0, 1, 0], [3.0, 3, 0]])
    bc = projected_barycentrics(pts, tri)
    np.testing.assert_allclose(bc[0], [0.5, 0.25, 0.25])  # height above the plane ignored
    np.testing.assert_allclose(bc[1], [0, 1, 0])
    np.testing.assert_allclose(bc[2], [2 / 3, 0, 1 / 3])  # (1, -0.5, 0.5) clamped, rescaled
    np.testing.assert_allclose(bc[3], [0, 0.5, 0.5])
    np.testing.assert_allclose(bc.sum(axis=1), 1)
    # a degenerate triangle gives finite coordinates, no division by zero
    flat = projected_barycentrics(np.zeros(3), np.zeros((1, 3, 3)))
    assert np.all(np.isfinite(flat)) and flat.sum() == pytest.approx(1)


def test_the_two_passes_find_what_every_candidate_finds():
    """The bounding-sphere cull skips no closer candidate: same distances (and the same
    points) as trying every triangle of the k nearest vertices, on a wavy irregular sheet."""
    V, F = _sheet(4)
    rng = np.random.default_rng(3)
    V = V + np.c_[0.02 * rng.normal(size=(len(V), 2)), 0.2 * np.sin(5 * V[:, 0])]
    sd = SurfaceDistance(V, F)
    P = V[rng.integers(0, len(V), 400)] + 0.05 * rng.normal(size=(400, 3))
    for k in (1, 4, 8):
        c, d, tri = sd.closest_triangles(P, k=k)
        _, nv = sd._tree.query(P, k=k)
        nv = nv.reshape(len(P), k)
        for i in range(len(P)):
            cand = np.flatnonzero(np.isin(F, nv[i]).any(axis=1))
            T = V[F[cand]]
            y = _closest_point_on_triangles(P[i], T[:, 0], T[:, 1], T[:, 2])
            dist = np.linalg.norm(y - P[i], axis=1)
            assert d[i] == pytest.approx(dist.min(), abs=1e-14)
            assert np.linalg.norm(c[i] - V[F[tri[i]]].mean(axis=0)) <= sd._radius[tri[i]] + 1e-12


def test_a_vertex_in_no_triangle_is_reported():
    V, F = _sheet(1)
    V = np.vstack([V, [[10.0, 10.0, 0.0]]])  # an isolated vertex, nearest to the query
    with pytest.raises(ValueError, match="no triangle"):
        SurfaceDistance(V, F).closest_triangles(np.array([[10.0, 10.0, 0.1]]), k=1)


def test_a_prepared_true_surface_gives_the_same_numbers_and_must_match():
    from conformorph.geometry.surface_distance import SurfaceDistance, surface_to_surface_error

    g = np.linspace(0.0, 1.0, 12)
    x, y = np.meshgrid(g, g)
    Vt = np.c_[x.ravel(), y.ravel(), 0.1 * np.sin(3 * x.ravel())]
    quads = np.arange(144).reshape(12, 12)[:-1, :-1].ravel()
    Ft = np.r_[np.c_[quads, quads + 1, quads + 13], np.c_[quads, quads + 13, quads + 12]]
    V = Vt + 0.01 * np.cos(5 * Vt[:, [1, 2, 0]])
    prepared = SurfaceDistance(Vt, Ft)
    assert surface_to_surface_error(V, Ft, Vt, Ft, true_surface=prepared) == (
        surface_to_surface_error(V, Ft, Vt, Ft)
    )
    with pytest.raises(ValueError, match="true_surface"):
        surface_to_surface_error(V, Ft, Vt + 1.0, Ft, true_surface=prepared)
