import importlib

import numpy as np
import pytest

from conformorph import geometry as g
from tests.meshes import (
    SHARED_FACES,
    bumpy_disk,
    disk_grid,
    folded_bumpy_disk,
    random_rotation,
    spherical_cap,
)

# the module (geometry re-exports a function of the same name)
disk_conformal_map_module = importlib.import_module("conformorph.geometry.disk_conformal_map")


def test_one_triangle_plus_centre_by_hand():
    # a fan of 6 equilateral triangles around a centre: by symmetry the map is the
    # regular hexagon on the unit circle with the centre at 0
    t = 2 * np.pi * np.arange(6) / 6
    V = np.vstack([[0, 0, 0], np.column_stack([np.cos(t), np.sin(t), np.zeros(6)])])
    F = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)])
    uv, info = g.disk_conformal_map(V, F)
    np.testing.assert_allclose(uv[0], 0, atol=1e-12)
    z = uv[1:, 0] + 1j * uv[1:, 1]
    np.testing.assert_allclose(np.abs(z), 1, atol=1e-12)
    np.testing.assert_allclose(np.diff(np.unwrap(np.angle(z))), np.pi / 3, atol=1e-12)
    assert info.flipped == 0 and info.iterations == 1


def test_single_triangle_is_inscribed_similar_triangle():
    V = np.array([[0.0, 0, 0], [3, 0, 0], [0.5, 2, 1]])
    F = np.array([[0, 1, 2]])
    uv, info = g.disk_conformal_map(V, F)
    np.testing.assert_allclose(np.hypot(*uv.T), 1, atol=1e-15)
    np.testing.assert_allclose(g.angle_distortion(V, F, uv), 0, atol=1e-12)
    assert info.flipped == 0 and info.method == "exact"
    with pytest.raises(ValueError, match="no interior vertex"):
        g.disk_conformal_map(
            np.vstack([V, [[3, 2, 0]]]), np.array([[0, 1, 2], [1, 3, 2]]), allow_ears=True
        )


def test_flat_disk_maps_to_itself_up_to_mobius():
    V, F = disk_grid(10)
    centre = int(np.argmin(np.hypot(V[:, 0], V[:, 1])))
    right = int(np.argmax(V[:, 0]))
    uv, info = g.disk_conformal_map(V, F, center_vertex=centre, angle_vertex=right)
    # the identity is the conformal map fixing 0 and 1; discrete error is O(h)
    assert np.abs(uv - V[:, :2]).max() < 0.02
    assert g.angle_distortion(V, F, uv).mean() < 0.5


def test_spherical_cap_matches_stereographic_projection():
    # for the polar cap, stereographic projection from the south pole is conformal
    # and maps the cap to a disk of radius tan(φ/2): scaled, it is the Riemann map
    errs = []
    for k in (6, 12, 24):
        V, F = spherical_cap(k)
        centre = int(np.argmax(V[:, 2]))
        uv, _ = g.disk_conformal_map(V, F, center_vertex=centre, angle_vertex=int(np.argmax(V[:, 0])))
        exact = V[:, :2] / (1 + V[:, 2:3])
        exact /= np.hypot(*exact.T).max()
        errs.append(np.abs(uv - exact).max())
    assert errs[-1] < 5e-3
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 1.5), f"expected about second-order convergence, got {rates}"


def test_boundary_on_circle_orientation_and_info():
    V, F = bumpy_disk()
    uv, info = g.disk_conformal_map(V, F)
    b = g.boundary_loop(F)
    assert np.abs(np.hypot(*uv[b].T) - 1).max() <= 1e-9
    assert np.all(np.hypot(*uv.T) <= 1 + 1e-12)
    assert (g.signed_areas_2d(uv, F) > 0).all()
    assert info.flipped == 0 and info.boundary_circle_error <= 1e-9
    assert set(info.seconds) >= {"validate", "assemble", "factor", "solve", "total"}
    assert g.angle_distortion(V, F, uv).mean() < 2.0


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_invariant_to_rigid_motion_scale_and_vertex_order(scale):
    V, F = bumpy_disk()
    c = 5
    right = int(g.boundary_loop(F)[0])
    uv0, _ = g.disk_conformal_map(V, F, center_vertex=c, angle_vertex=right)
    R = random_rotation(3)
    V1 = scale * V @ R.T + np.array([3.0, -2.0, 7.0])
    perm = np.random.default_rng(0).permutation(len(V))
    inv = np.argsort(perm)
    V2 = V1[perm]
    F2 = inv[F]
    V_copy = V2.copy()
    uv2, _ = g.disk_conformal_map(V2, F2, center_vertex=int(inv[c]), angle_vertex=int(inv[right]))
    np.testing.assert_array_equal(V2, V_copy)
    np.testing.assert_allclose(uv2[inv], uv0, atol=1e-9)


def test_fold_policies():
    V, F = folded_bumpy_disk()
    uv, info = g.disk_conformal_map(V, F, fold_policy="report")
    assert info.flipped > 0 and not info.bijective
    with pytest.raises(g.FoldedMapError):
        g.disk_conformal_map(V, F, fold_policy="raise")
    uv, info = g.disk_conformal_map(V, F)
    assert info.flipped == 0 and info.flipped_before_repair > 0 and info.repaired_vertices > 0
    assert not g.flipped_triangles(uv, F).any()


def test_local_repair_moves_few_vertices_and_keeps_angles(monkeypatch):
    V, F = folded_bumpy_disk()
    # without the final angle refinement, which moves every interior vertex
    folded, _ = g.disk_conformal_map(V, F, fold_policy="report", refine_angles=False)
    uv, info = g.disk_conformal_map(V, F, refine_angles=False)
    rec = info.extra["repair"]
    assert rec["method"] == "local_conformal" and rec["relaxation"]["stop_reason"] == "converged"
    moved = np.linalg.norm(uv - folded, axis=1) > 1e-12
    assert moved.sum() == info.repaired_vertices < len(V) // 4
    # the global mean-value repair (the fallback) moves every interior vertex and
    # distorts angles more
    monkeypatch.setattr(disk_conformal_map_module, "REPAIR_MAX_RINGS", 0)
    uv_mv, info_mv = g.disk_conformal_map(V, F, refine_angles=False)
    assert info_mv.flipped == 0 and info_mv.extra["repair"]["method"] == "mean_value"
    assert g.angle_distortion(V, F, uv).mean() < g.angle_distortion(V, F, uv_mv).mean()


def test_bad_method_rejected():
    V, F = disk_grid(3)
    with pytest.raises(ValueError, match="method"):
        g.disk_conformal_map(V, F, method="nope")


@pytest.mark.skipif(not SHARED_FACES.exists(), reason="../shared/data is absent")
def test_choi_face_quality():
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(SHARED_FACES / "choi_human_face.obj")
    uv, info = g.disk_conformal_map(V, F)
    assert info.flipped == 0
    assert g.angle_distortion(V, F, uv).mean() <= 1.2


def test_green_disk_map_is_harmonic_with_its_pole_at_the_centroid():
    # the fast method's stage: boundary on the unit circle in boundary order, interior
    # solving the cotangent Laplace equation, pole = interior vertex nearest the centroid
    V, F = bumpy_disk(6)
    b = g.boundary_loop(F)
    interior = np.setdiff1d(np.arange(len(V)), b)
    L = g.cotangent_laplacian(V, F)
    fac = g.factorize(L[interior][:, interior], symmetric=True)
    uv, pole, nonpositive = g.green_disk_map(
        V, F, fac, L[b][:, interior], L[interior][:, b], b, interior
    )
    np.testing.assert_allclose(np.hypot(*uv[b].T), 1, atol=1e-14)
    assert np.all(np.diff(np.unwrap(np.arctan2(uv[b, 1], uv[b, 0]))) > 0)
    res = L[interior][:, interior] @ uv[interior] + L[interior][:, b] @ uv[b]
    assert np.abs(res).max() < 1e-12
    A = g.vertex_areas(V, F)
    c = (A[:, None] * V).sum(0) / A.sum()
    assert pole == interior[np.argmin(np.linalg.norm(V[interior] - c, axis=1))]
    assert nonpositive == 0
    # and it is disk_conformal_map's fast map without the refinement
    ref, info = g.disk_conformal_map(V, F, refine_angles=False)
    np.testing.assert_allclose(uv, ref, atol=1e-14)
    assert info.center_vertex == pole


def test_qiem_options_reach_the_qiem_route():
    V, F = bumpy_disk(4)
    opts = g.QiemOptions(max_iterations=1)
    _, info = g.disk_conformal_map(V, F, method="qiem", fold_policy="report", qiem_options=opts)
    assert info.extra["iterations"] == 1 and info.extra["stop_reason"] == "max_iterations"
