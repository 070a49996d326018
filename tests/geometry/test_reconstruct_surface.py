import numpy as np
import pytest

from conformorph import geometry as g
from tests.meshes import SHARED_FACES, bumpy_disk, spherical_cap


def analyse(V, F):
    # as the reconstruct command and the face pipeline: the harmonic map itself
    uv, _ = g.disk_conformal_map(V, F, fold_policy="report", refine_angles=False)
    return uv, g.conformal_factor(V, F, uv)


def test_flat_disk_stays_in_its_plane():
    # H = 0: the reconstruction is the disk-harmonic extension of a planar boundary,
    # which lies exactly in the plane and, the map being nearly linear, near V
    V, F = bumpy_disk(6)
    V[:, 2] = 0.0
    uv, lam = analyse(V, F)
    b = g.boundary_loop(F)
    H = g.mean_curvature(V, F)
    np.testing.assert_allclose(H, 0, atol=1e-12)
    X, info = g.reconstruct_surface(uv, F, H, lam, V[b])
    np.testing.assert_allclose(X[:, 2], 0, atol=1e-14)
    assert np.abs(X - V).max() < 1e-5


def test_sphere_mean_curvature_is_inverse_radius():
    V, F = spherical_cap(16, height=0.8)
    H = g.mean_curvature(V, F)
    interior = np.setdiff1d(np.arange(len(V)), g.boundary_loop(F))
    # outward faces: H = 1/r = 1 (faces are CCW seen from +z, i.e. outward at the pole)
    assert np.median(np.abs(np.abs(H[interior]) - 1.0)) < 0.02


def test_conformal_factor_of_scaled_copy():
    V, F = bumpy_disk(6)
    uv, lam = analyse(V, F)
    np.testing.assert_allclose(g.conformal_factor(3 * V, F, uv), 9 * lam, rtol=1e-12)


@pytest.mark.parametrize("mode", ["vector", "scalar"])
def test_reconstruction_converges_under_refinement(mode):
    errs = []
    for k in (6, 12, 24):
        V, F = bumpy_disk(k)
        uv, lam = analyse(V, F)
        H = g.mean_curvature_vector(V, F) if mode == "vector" else g.mean_curvature(V, F)
        b = g.boundary_loop(F)
        X, info = g.reconstruct_surface(uv, F, H, lam, V[b])
        errs.append(g.reconstruction_error(V, X, F)["L2"])
    assert errs[-1] < errs[0]
    if mode == "vector":
        assert errs[-1] < 2e-3
        rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
        assert np.all(rates > 1.0), rates


def test_operator_reuse_and_validation():
    V, F = bumpy_disk(6)
    uv, lam = analyse(V, F)
    b = g.boundary_loop(F)
    op = g.reconstruction_operator(uv, F)
    Hn = g.mean_curvature_vector(V, F)
    X1, _ = g.reconstruct_surface(uv, F, Hn, lam, V[b], operator=op)
    X2, _ = g.reconstruct_surface(uv, F, Hn, lam, V[b])
    np.testing.assert_allclose(X1, X2, atol=1e-12)
    with pytest.raises(ValueError, match="lam"):
        g.reconstruct_surface(uv, F, Hn, -lam, V[b])
    with pytest.raises(ValueError, match="boundary_positions"):
        g.reconstruct_surface(uv, F, Hn, lam, V[b][:-1])


def test_reconstruction_error_by_hand():
    V, F = bumpy_disk(4)
    shift = np.array([0.0, 0.0, 0.01])
    e = g.reconstruction_error(V, V + shift, F)
    diag = np.linalg.norm(V.max(0) - V.min(0))
    for k in ("L1", "L2", "Linf"):
        assert e[k] == pytest.approx(0.01 / diag)


@pytest.mark.skipif(not SHARED_FACES.exists(), reason="../shared/data is absent")
def test_ict_face_vector_reconstruction_target():
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(SHARED_FACES / "ict_generic_jawOpen.obj")
    uv, lam = analyse(V, F)
    b = g.boundary_loop(F)
    X, _ = g.reconstruct_surface(uv, F, g.mean_curvature_vector(V, F), lam, V[b])
    e = g.reconstruction_error(V, X, F)
    assert e["L2"] <= 1e-3 and e["Linf"] <= 5e-3


@pytest.mark.parametrize(
    "F",
    [np.array([[0, 1, 2]]), np.array([[0, 1, 2], [0, 2, 3]])],
    ids=["one_triangle", "open_fan"],
)
def test_no_interior_vertex_is_refused_with_a_reason(F):
    n = int(F.max()) + 1
    t = 2 * np.pi * np.arange(n) / n
    uv = np.column_stack([np.cos(t), np.sin(t)])
    V = np.column_stack([uv, np.zeros(n)])
    with pytest.raises(g.NoInteriorVertexError, match="interior vertex.*nothing to reconstruct"):
        g.reconstruct_surface(uv, F, np.zeros((n, 3)), np.ones(n), V)
    with pytest.raises(ValueError):  # a MeshError, itself a ValueError
        g.reconstruction_operator(uv, F)


def test_curvature_direction_normals_on_a_sphere_cap_point_along_the_radius():
    # on a sphere the mean-curvature vector is radial: the normals it gives are ±V/|V|,
    # signed like the reference normals, at interior vertices
    V, F = spherical_cap(16, height=0.8)
    interior = np.setdiff1d(np.arange(len(V)), g.boundary_loop(F))
    N0 = g.vertex_normals(V, F)
    N = g.curvature_direction_normals(V, F, N0)
    np.testing.assert_allclose(np.linalg.norm(N, axis=1), 1.0, atol=1e-12)
    assert np.all(np.einsum("ij,ij->i", N, N0) > 0)
    radial = V[interior] / np.linalg.norm(V[interior], axis=1, keepdims=True)
    cos = np.abs(np.einsum("ij,ij->i", N[interior], radial))
    assert np.median(cos) > 0.999


def test_normal_update_iteration_is_the_scalar_path_of_reconstruct_surface():
    V, F = bumpy_disk(6)
    uv, lam = analyse(V, F)
    b = g.boundary_loop(F)
    H = g.mean_curvature(V, F)
    opts = g.ReconstructionOptions(max_iterations=7, tol=0.0)
    op = g.reconstruction_operator(uv, F)
    X, history, stop = g.normal_update_iteration(op, H, lam * op.area_uv, V[b], opts)
    X2, info = g.reconstruct_surface(uv, F, H, lam, V[b], options=opts)
    assert (len(history), stop) == (7, "max_iterations") == (info.iterations, info.stop_reason)
    np.testing.assert_array_equal(X, X2)
    # with the change measured per iterate, and a solve that keeps the boundary
    np.testing.assert_array_equal(X[b], V[b])
    assert history[-1] < history[0]
