import numpy as np
import pytest
import trimesh

from conformorph.geometry.double_cover import double_cover
from conformorph.geometry.qiem_disk_map import harmonic_hemisphere_map
from conformorph.geometry.spherical_conformal_map import (
    SphericalMapOptions,
    center_on_sphere,
    gauss_map,
    spherical_conformal_map,
)
from conformorph.geometry.vertex_areas import vertex_areas
from tests.meshes import bumpy_disk, disk_grid, random_rotation

OCTA_V = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
OCTA_F = np.array(
    [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
)


def ellipsoid(subdivisions=2, axes=(1.0, 1.4, 0.7)):
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    return np.asarray(m.vertices) * axes, np.asarray(m.faces, dtype=np.int64)


def spherical_orientation(phi, F):
    e1 = phi[F[:, 1]] - phi[F[:, 0]]
    e2 = phi[F[:, 2]] - phi[F[:, 0]]
    return np.einsum("ij,ij->i", np.cross(e1, e2), phi[F].mean(axis=1))


def procrustes_error(A, B):
    U, _, Wt = np.linalg.svd(B.T @ A)
    return np.abs(A - B @ (U @ Wt)).max()


@pytest.mark.parametrize("scheme", ["qiem", "lagged"])
def test_octahedron_is_a_fixed_point_by_hand(scheme):
    # by symmetry the Gauss map of the octahedron (its own vertices) is harmonic:
    # L phi_i is parallel to phi_i, so the flow must not move it
    phi, info = spherical_conformal_map(
        OCTA_V * 3.0, OCTA_F, options=SphericalMapOptions(scheme=scheme)
    )
    np.testing.assert_allclose(phi, OCTA_V, atol=1e-12)
    assert info.stop_reason == "converged" and info.iterations == 1
    # E_D of the octahedron map: 6 vertices, 12 edges of weight cot(60°)... = 4 sqrt(3) (area 4π scaling
    # does not change L): E = 1/2 sum_edges w_e |e|^2 = 1/2 * 12 * (2 * cot(pi/3) / 2) * 2
    assert info.energy_history[-1] == pytest.approx(12 * (1 / np.sqrt(3)), rel=1e-12)


@pytest.mark.parametrize("scheme", ["lagged", "qiem"])
def test_ellipsoid_converges_to_a_bijective_harmonic_map(scheme):
    V, F = ellipsoid(2)
    phi, info = spherical_conformal_map(
        V, F, options=SphericalMapOptions(scheme=scheme, time_step=0.5, growth=1.0)
    )
    assert info.stop_reason == "converged"
    np.testing.assert_allclose(np.linalg.norm(phi, axis=1), 1, atol=1e-14)
    assert np.all(spherical_orientation(phi, F) > 0)
    E = info.energy_history
    assert np.all(np.diff(E) <= 1e-9 * E[0])  # monotone up to the centring round-off
    assert info.conformal_energy_history[-1] < 0.1 * info.conformal_energy_history[0]
    assert info.conformal_energy_history[-1] >= -1e-9
    # harmonic map: the tangential part of L phi vanishes (Lφ = M D φ)
    from conformorph.geometry.cotangent_laplacian import cotangent_laplacian

    Lp = cotangent_laplacian(V, F) @ phi
    tang = Lp - np.einsum("ij,ij->i", Lp, phi)[:, None] * phi
    assert np.abs(tang).max() < 1e-3 * np.abs(Lp).max()


def test_schemes_agree_up_to_rotation():
    V, F = ellipsoid(2)
    a, _ = spherical_conformal_map(V, F, options=SphericalMapOptions(scheme="lagged", tol=1e-8))
    b, _ = spherical_conformal_map(
        V, F, options=SphericalMapOptions(scheme="qiem", tol=1e-8, time_step=0.5)
    )
    assert procrustes_error(a, b) < 1e-5


def test_conformal_energy_falls_under_refinement():
    ec = []
    for s in (1, 2, 3):
        V, F = ellipsoid(s)
        _, info = spherical_conformal_map(V, F, options=SphericalMapOptions(tol=1e-7))
        ec.append(info.conformal_energy_history[-1])
    rates = np.log2(np.array(ec[:-1]) / np.array(ec[1:]))
    assert np.all(rates > 1.5), f"E_D - A should fall about as h^2, got rates {rates}"


def test_invariance_rotation_scale_and_vertex_order():
    V, F = ellipsoid(2)
    phi, _ = spherical_conformal_map(V, F)
    R = random_rotation(7)
    phiR, _ = spherical_conformal_map(V @ R.T + [1, 2, 3], F)
    np.testing.assert_allclose(phiR, phi @ R.T, atol=1e-9)
    for s in (1e-3, 1e3):
        np.testing.assert_allclose(spherical_conformal_map(s * V, F)[0], phi, atol=1e-9)
    perm = np.random.default_rng(1).permutation(V.shape[0])
    inv = np.argsort(perm)
    phiP, _ = spherical_conformal_map(V[perm], inv[F])
    np.testing.assert_allclose(phiP, phi[perm], atol=1e-9)


def test_inputs_not_mutated():
    V, F = ellipsoid(1)
    phi0 = gauss_map(V, F)
    copies = [x.copy() for x in (V, F, phi0)]
    spherical_conformal_map(V, F, initial_map=phi0)
    for x, y in zip((V, F, phi0), copies, strict=True):
        np.testing.assert_array_equal(x, y)


def test_center_on_sphere_moves_mass_centre_to_origin():
    V, F = ellipsoid(2)
    M = vertex_areas(V, F)
    phi = gauss_map(V, F) + [0.3, 0, 0]
    phi /= np.linalg.norm(phi, axis=1, keepdims=True)
    c0 = np.abs((M[:, None] * phi).sum(0)).max()
    out = center_on_sphere(phi, M)
    for _ in range(20):
        out = center_on_sphere(out, M)
    assert np.abs((M[:, None] * out).sum(0)).max() < 1e-3 * c0
    assert M.sum() == pytest.approx(trimesh.Trimesh(V, F, process=False).area)


def test_bad_inputs_raise():
    V, F = disk_grid(3)
    dc = double_cover(V, F)
    with pytest.raises(ValueError, match="normal vanishes"):
        gauss_map(dc.V, dc.F)  # the two sheets' normals cancel
    with pytest.raises(ValueError):
        spherical_conformal_map(OCTA_V, OCTA_F, options=SphericalMapOptions(scheme="explicit"))
    with pytest.raises(ValueError):
        spherical_conformal_map(OCTA_V, OCTA_F, initial_map=OCTA_V[:3])
    with pytest.raises(ValueError):
        spherical_conformal_map(OCTA_V, OCTA_F, options=SphericalMapOptions(time_step=-1.0))
    with pytest.raises(ValueError):
        spherical_conformal_map(OCTA_V[:, :2], OCTA_F)


@pytest.mark.parametrize("scheme", ["lagged", "qiem"])
def test_mirror_split_gives_the_same_iterates_as_the_full_solve(scheme):
    V, F = bumpy_disk(6)
    dc = double_cover(V, F)
    phi0 = harmonic_hemisphere_map(V, F, dc)
    opts = {
        "options": SphericalMapOptions(scheme=scheme, time_step=0.1, max_iterations=5, tol=1e-12)
    }
    full, i_full = spherical_conformal_map(dc.V, dc.F, initial_map=phi0, **opts)
    half, i_half = spherical_conformal_map(dc.V, dc.F, initial_map=phi0, mirror=dc.mirror, **opts)
    np.testing.assert_allclose(half, full, atol=1e-11)
    np.testing.assert_allclose(i_half.energy_history, i_full.energy_history, rtol=1e-12)
    np.testing.assert_array_equal(half[dc.b, 2], 0.0)
    np.testing.assert_allclose(half[dc.mirror], half * [1, 1, -1], atol=1e-15)


def test_mirror_must_be_an_involution_and_the_start_symmetric():
    V, F = bumpy_disk(4)
    dc = double_cover(V, F)
    phi0 = harmonic_hemisphere_map(V, F, dc)
    with pytest.raises(ValueError, match="involution"):
        spherical_conformal_map(dc.V, dc.F, initial_map=phi0, mirror=np.roll(dc.mirror, 1))
    bad = phi0.copy()
    bad[:, 2] = np.abs(bad[:, 2]) + 0.1
    with pytest.raises(ValueError, match="mirror-symmetric"):
        spherical_conformal_map(dc.V, dc.F, initial_map=bad, mirror=dc.mirror)


@pytest.mark.parametrize("scheme", ["qiem", "lagged"])
def test_heat_flow_stages_mass_cap_and_fixed_point(scheme):
    # the stages of the flow: lumped mass scaled to area 4π, the QIEM cap keeps
    # M - dt M D positive, and one step leaves the harmonic octahedron map in place
    from conformorph.geometry.spherical_conformal_map import QIEM_DT_SAFETY, _HeatFlow

    flow = _HeatFlow(OCTA_V * 3.0, OCTA_F, scheme, None)
    assert flow.M.sum() == pytest.approx(4 * np.pi, rel=1e-14)
    np.testing.assert_allclose(flow.M, 4 * np.pi / 6, rtol=1e-14)
    MD = flow.flux(OCTA_V)
    dt = flow.capped_time_step(MD, 100.0)
    if scheme == "qiem":
        assert dt == pytest.approx(QIEM_DT_SAFETY / (MD / flow.M).max(), rel=1e-14)
        assert np.all(flow.M - dt * MD > 0)
    else:
        assert dt == 100.0
    np.testing.assert_allclose(flow.step(OCTA_V, MD, dt), OCTA_V, atol=1e-12)
    assert flow.factorizations == 1
