import numpy as np
import pytest

from conformorph.geometry.angle_distortion import angle_distortion
from conformorph.geometry.boundary_loop import boundary_loop
from conformorph.geometry.double_cover import double_cover
from conformorph.geometry.flipped_triangles import flipped_triangles, signed_areas_2d
from conformorph.geometry.mesh_errors import MeshError
from conformorph.geometry.mobius import normalize_disk_map
from conformorph.geometry.qiem_disk_map import (
    QiemOptions,
    double_cover_gauss_map,
    harmonic_hemisphere_map,
    qiem_disk_conformal_map,
)
from tests.meshes import SHARED_FACES, bumpy_disk, disk_grid, random_rotation, spherical_cap


def _square(height=0.0):
    V = np.array([[0.0, 0, height], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    return V, F


@pytest.mark.parametrize("height", [0.0, 0.7])
def test_square_pyramid_by_hand(height):
    # four-fold symmetry: the apex goes to 0, the corners to four points 90° apart
    V, F = _square(height)
    uv, info = qiem_disk_conformal_map(V, F)
    np.testing.assert_allclose(uv[0], 0, atol=1e-12)
    z = uv[1:, 0] + 1j * uv[1:, 1]
    np.testing.assert_allclose(np.abs(z), 1, atol=1e-12)
    np.testing.assert_allclose(np.diff(np.unwrap(np.angle(z))), np.pi / 2, atol=1e-9)
    assert info.flipped == 0


def test_flat_disk_maps_to_itself_up_to_mobius_with_second_order():
    errs = []
    for k in (6, 12, 24):
        V, F = disk_grid(k)
        uv, _ = qiem_disk_conformal_map(V, F, center_vertex=0, angle_vertex=int(np.argmax(V[:, 0])))
        errs.append(np.abs(uv - V[:, :2]).max())
    assert errs[-1] < 5e-4
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 1.7), f"expected second-order convergence, got {rates}"


def test_spherical_cap_matches_stereographic_projection():
    errs = []
    for k in (6, 12, 24):
        V, F = spherical_cap(k)
        c, a = int(np.argmax(V[:, 2])), int(np.argmax(V[:, 0]))
        uv, _ = qiem_disk_conformal_map(V, F, center_vertex=c, angle_vertex=a)
        exact = V[:, :2] / (1 + V[:, 2:3])
        exact /= np.hypot(*exact.T).max()
        errs.append(np.abs(uv - exact).max())
    assert errs[-1] < 2e-4
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(rates > 1.7), f"expected second-order convergence, got {rates}"


def test_boundary_circle_orientation_and_info():
    V, F = bumpy_disk(10)
    uv, info = qiem_disk_conformal_map(V, F)
    b = boundary_loop(F)
    assert np.abs(np.hypot(*uv[b].T) - 1).max() <= 1e-9
    assert np.all(np.hypot(*uv.T) <= 1 + 1e-12)
    assert np.all(signed_areas_2d(uv, F) > 0) and info.flipped == 0
    assert info.stop_reason == "converged" and info.factorizations == 1
    assert info.boundary_deviation < 1e-9  # the symmetric flow keeps the seam on the equator
    assert len(info.energy_history) == info.iterations + 1
    # the flow lowers the energy; the mass-centre normalisation (not an exact discrete
    # Möbius map) may raise it by round-off-sized amounts near convergence
    assert np.all(np.diff(info.energy_history) <= 1e-6 * info.energy_history[0])
    assert info.energy_history[-1] < info.energy_history[0]
    assert set(info.seconds) == {"cover", "initial_map", "sphere", "project", "normalize", "total"}
    assert angle_distortion(V, F, uv).mean() < 1.0


def test_paper_scheme_and_gauss_start_reach_the_same_map_on_a_cap():
    V, F = spherical_cap(6)
    c, a = int(np.argmax(V[:, 2])), int(np.argmax(V[:, 0]))
    ref, _ = qiem_disk_conformal_map(
        V, F, center_vertex=c, angle_vertex=a, options=QiemOptions(tol=1e-8)
    )
    exact = V[:, :2] / (1 + V[:, 2:3])
    exact /= np.hypot(*exact.T).max()
    err = np.abs(ref - exact).max()
    uv, info = qiem_disk_conformal_map(
        V,
        F,
        center_vertex=c,
        angle_vertex=a,
        options=QiemOptions(tol=1e-8, scheme="qiem", time_step=0.1),
    )
    assert info.stop_reason == "converged" and info.factorizations >= info.iterations
    assert np.abs(uv - ref).max() < 1e-6  # same fixed point as the lagged scheme
    # the Gauss start is not symmetric in the two sheets, so its seam is off the
    # equator and its discrete map differs, but only within the discretisation error
    uv, info = qiem_disk_conformal_map(
        V,
        F,
        center_vertex=c,
        angle_vertex=a,
        options=QiemOptions(tol=1e-8, initial_map="gauss", max_iterations=500),
    )
    assert info.stop_reason == "converged" and info.boundary_deviation > 1e-9
    assert np.abs(uv - exact).max() < 2 * err


def _normalised(uv, b, c, a):
    return normalize_disk_map(uv, b, c, a)


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_invariance_to_rigid_motion_scale_and_vertex_order(scale):
    V, F = bumpy_disk(8)
    b = boundary_loop(F)
    c, a = 5, int(b[4])
    ref = _normalised(qiem_disk_conformal_map(V, F)[0], b, c, a)
    R = random_rotation(11)
    W = scale * V @ R.T + [3.0, -2.0, 1.0]
    perm = np.random.default_rng(2).permutation(V.shape[0])
    inv = np.argsort(perm)  # new index of old vertex i is inv[i]
    uv, _ = qiem_disk_conformal_map(W[perm], inv[F])
    bp = boundary_loop(inv[F])
    got = _normalised(uv, bp, int(inv[c]), int(inv[a]))
    np.testing.assert_allclose(got[inv], ref, atol=1e-8)


def test_default_normalisation_is_intrinsic_up_to_rotation():
    # without center/angle vertices, the sphere's mass-centre normalisation fixes the
    # Möbius freedom up to a rotation: |uv| does not depend on the placement
    V, F = bumpy_disk(8)
    uv, _ = qiem_disk_conformal_map(V, F)
    uv2, _ = qiem_disk_conformal_map(1e3 * V @ random_rotation(4).T, F)
    np.testing.assert_allclose(np.hypot(*uv2.T), np.hypot(*uv.T), atol=1e-8)


def test_inputs_not_mutated():
    V, F = bumpy_disk(5)
    V0, F0 = V.copy(), F.copy()
    qiem_disk_conformal_map(V, F)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)


def test_bad_inputs_raise():
    V, F = _square()
    with pytest.raises(ValueError):
        qiem_disk_conformal_map(V, F, options=QiemOptions(initial_map="tutte"))
    closed_F = np.vstack([F, np.array([[1, 2, 3], [1, 3, 4]])[:, ::-1]])
    with pytest.raises(MeshError):
        qiem_disk_conformal_map(V, closed_F)
    with pytest.raises(MeshError):
        qiem_disk_conformal_map(V[:, :2], F)


@pytest.mark.shared_data
def test_choi_human_face_target():
    path = SHARED_FACES / "choi_human_face.obj"
    if not path.exists():
        pytest.skip("../shared/data is absent")
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(path)
    uv, info = qiem_disk_conformal_map(V, F)
    b = boundary_loop(F, V)
    assert np.abs(np.hypot(*uv[b].T) - 1).max() <= 1e-9
    assert info.flipped == 0
    assert angle_distortion(V, F, uv).mean() < 1.22  # FACTS: 1.21° with Choi's spherical map


def test_harmonic_hemisphere_start_is_mirror_symmetric_with_seam_on_equator():
    V, F = bumpy_disk(6)
    dc = double_cover(V, F)
    phi = harmonic_hemisphere_map(V, F, dc)
    n = V.shape[0]
    np.testing.assert_allclose(np.linalg.norm(phi, axis=1), 1, atol=1e-14)
    np.testing.assert_allclose(phi[dc.b, 2], 0, atol=1e-15)
    np.testing.assert_allclose(phi[dc.twin], phi[:n] * [1, 1, -1], atol=1e-15)
    assert np.all(phi[:n][np.setdiff1d(np.arange(n), dc.b), 2] > 0)


def test_double_cover_gauss_map_of_a_flat_disk():
    # sheet one looks up (+z), sheet two down, the seam points radially outward
    V, F = disk_grid(4)
    dc = double_cover(V, F)
    phi = double_cover_gauss_map(V, F, dc)
    n = V.shape[0]
    inner = np.setdiff1d(np.arange(n), dc.b)
    np.testing.assert_allclose(phi[inner], [[0, 0, 1]] * inner.size, atol=1e-14)
    np.testing.assert_allclose(phi[dc.twin[inner]], [[0, 0, -1]] * inner.size, atol=1e-14)
    np.testing.assert_allclose(phi[dc.b], V[dc.b], atol=1e-12)  # unit circle: outward normal


@pytest.mark.shared_data
def test_ict_mouth_fold_flips_are_reported():
    path = SHARED_FACES / "ict_generic_neutral.obj"
    if not path.exists():
        pytest.skip("../shared/data is absent")
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(path)
    uv, info = qiem_disk_conformal_map(V, F)
    flips = int(flipped_triangles(uv, F).sum())
    assert info.flipped == flips > 0  # the inner-lip fold (FACTS: 18 with every method)
    b = boundary_loop(F, V)
    assert np.abs(np.hypot(*uv[b].T) - 1).max() <= 1e-9
