import numpy as np
import pytest

from conformorph import geometry as g
from conformorph.geometry.angle_distortion import corner_angles, corner_edge_products
from conformorph.geometry.angle_refinement import (
    _angle_jacobian,
    refine_angles,
    signed_corner_angles,
)
from tests.meshes import SHARED_FACES, bumpy_disk, disk_grid


def _hexagon_fan(centre=(0.0, 0.0)):
    t = 2 * np.pi * np.arange(6) / 6
    uv = np.vstack([centre, np.column_stack([np.cos(t), np.sin(t)])])
    F = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in range(6)])
    return uv, F


def test_signed_angles_by_hand():
    uv = np.array([[0.0, 0], [1, 0], [0, 1]])
    F = np.array([[0, 1, 2]])
    np.testing.assert_allclose(signed_corner_angles(uv, F), [[np.pi / 2, np.pi / 4, np.pi / 4]])
    # the same triangle clockwise: every angle negative
    np.testing.assert_allclose(
        signed_corner_angles(uv, F[:, [0, 2, 1]]), -signed_corner_angles(uv, F)
    )


def test_jacobian_matches_finite_differences():
    rng = np.random.default_rng(1)
    V, F = disk_grid(3)
    uv = V[:, :2] + 0.02 * rng.standard_normal((len(V), 2))
    E, _, _ = corner_edge_products(uv, F)
    J = _angle_jacobian(E, F, len(uv)).toarray()
    h = 1e-7
    for col in rng.choice(2 * len(uv), 12, replace=False):
        d = np.zeros(2 * len(uv))
        d[col] = h
        fd = (
            signed_corner_angles(uv + d.reshape(-1, 2), F)
            - signed_corner_angles(uv - d.reshape(-1, 2), F)
        ) / (2 * h)
        np.testing.assert_allclose(J[:, col], fd.reshape(-1), atol=1e-6)
    # angles are translation invariant: each row's x and y entries sum to 0
    np.testing.assert_allclose(J[:, 0::2].sum(axis=1), 0, atol=1e-12)
    np.testing.assert_allclose(J[:, 1::2].sum(axis=1), 0, atol=1e-12)


def test_hexagon_centre_returns_to_the_centre():
    # regular hexagon boundary fixed, 60° targets: the only exact solution is the
    # centre at 0; every step lowers the error and the iteration converges to it
    uv, F = _hexagon_fan(centre=(0.3, -0.2))
    free = np.zeros(7, dtype=bool)
    free[0] = True
    beta = np.full(F.shape, np.pi / 3)
    errors = []
    for _ in range(30):
        uv, info = refine_angles(uv, F, beta, free)
        errors.append(info.mean_error_after)
        assert info.mean_error_after <= info.mean_error_before
    assert np.linalg.norm(uv[0]) < 1e-6
    assert errors[-1] < 1e-4
    t = 2 * np.pi * np.arange(6) / 6
    np.testing.assert_array_equal(uv[1:], np.column_stack([np.cos(t), np.sin(t)]))


def test_realizable_targets_are_recovered():
    # targets are the angles of a planar mesh: a perturbation of its interior is
    # pulled back, the mean error falling by orders of magnitude
    V, F = disk_grid(6)
    exact = V[:, :2]
    b = g.boundary_loop(F)
    free = np.ones(len(V), dtype=bool)
    free[b] = False
    rng = np.random.default_rng(0)
    uv = exact + 0.02 * rng.standard_normal(exact.shape) * free[:, None]
    beta = corner_angles(exact, F)
    first = None
    for _ in range(40):
        uv, info = refine_angles(uv, F, beta, free)
        first = info.mean_error_before if first is None else first
    assert info.mean_error_after < 1e-3 * first
    assert np.abs(uv - exact).max() < 1e-4


def test_invariant_to_similarity_and_vertex_order():
    V, F = bumpy_disk()
    uv, _ = g.disk_conformal_map(V, F, refine_angles=False)
    beta = corner_angles(V, F)
    free = np.ones(len(V), dtype=bool)
    free[g.boundary_loop(F)] = False
    out, info = refine_angles(uv, F, beta, free)
    assert info.step > 0 and info.mean_error_after < info.mean_error_before
    c, s = np.cos(1.1), np.sin(1.1)
    R = np.array([[c, -s], [s, c]])
    perm = np.random.default_rng(3).permutation(len(V))
    inv = np.argsort(perm)
    uv2 = (3e-3 * uv @ R.T + [5.0, -1.0])[perm]
    out2, info2 = refine_angles(uv2, inv[F], beta, free[perm])
    np.testing.assert_allclose(out2[inv], 3e-3 * out @ R.T + [5.0, -1.0], atol=1e-12)
    assert info2.mean_error_after == pytest.approx(info.mean_error_after, rel=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_never_flips_and_never_raises_the_error(seed):
    # targets far from realizable (random): the line search keeps every triangle
    # counter-clockwise and rejects a step that does not lower the error
    rng = np.random.default_rng(seed)
    V, F = disk_grid(4)
    uv = V[:, :2]
    beta = corner_angles(V, F) * np.exp(0.5 * rng.standard_normal(F.shape))
    free = np.ones(len(V), dtype=bool)
    free[g.boundary_loop(F)] = False
    for _ in range(5):
        uv, info = refine_angles(uv, F, beta, free)
        assert (g.signed_areas_2d(uv, F) > 0).all()
        assert info.mean_error_after <= info.mean_error_before


def test_nothing_free_or_already_exact_returns_the_input():
    uv, F = _hexagon_fan()
    beta = np.full(F.shape, np.pi / 3)
    out, info = refine_angles(uv + [0.1, 0], F, beta, np.zeros(7, dtype=bool))
    np.testing.assert_array_equal(out, uv + [0.1, 0])
    assert info.step == 0.0
    # already exact (to round-off): nothing moves beyond round-off
    out, info = refine_angles(uv, F, beta, np.ones(7, dtype=bool))
    assert info.mean_error_before < 1e-12 and info.mean_error_after < 1e-12
    np.testing.assert_allclose(out, uv, atol=1e-13)


def test_bad_input_rejected():
    uv, F = _hexagon_fan()
    beta = np.full(F.shape, np.pi / 3)
    free = np.ones(7, dtype=bool)
    with pytest.raises(ValueError, match="flipped"):
        refine_angles(uv, F[:, [0, 2, 1]], beta, free)
    with pytest.raises(ValueError, match="target_angles"):
        refine_angles(uv, F, beta[:3], free)
    with pytest.raises(ValueError, match="free"):
        refine_angles(uv, F, beta, free[:3])
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        refine_angles(np.zeros((7, 3)), F, beta, free)
    with pytest.raises(ValueError, match="cg_iterations"):
        refine_angles(uv, F, beta, free, cg_iterations=0)


def test_disk_map_refinement_lowers_distortion_and_keeps_the_disk():
    V, F = bumpy_disk()
    plain, _ = g.disk_conformal_map(V, F, refine_angles=False)
    uv, info = g.disk_conformal_map(V, F)
    rec = info.extra["angle_refinement"]
    assert rec["step"] > 0 and "refine" in info.seconds
    assert g.angle_distortion(V, F, uv).mean() < g.angle_distortion(V, F, plain).mean()
    assert rec["mean_error_after"] == pytest.approx(g.angle_distortion(V, F, uv).mean(), rel=1e-9)
    b = g.boundary_loop(F)
    np.testing.assert_array_equal(uv[b], plain[b])
    assert info.flipped == 0 and not g.flipped_triangles(uv, F).any()
    # the paper's route is left as it is
    _, qinfo = g.disk_conformal_map(V, F, method="qiem")
    assert "angle_refinement" not in qinfo.extra


@pytest.mark.skipif(not SHARED_FACES.exists(), reason="../shared/data is absent")
def test_choi_face_distortion_target():
    from conformorph.pipelines.mesh_io import read_mesh

    V, F = read_mesh(SHARED_FACES / "choi_human_face.obj")
    plain, _ = g.disk_conformal_map(V, F, refine_angles=False)
    uv, info = g.disk_conformal_map(V, F)
    assert info.flipped == 0
    assert g.angle_distortion(V, F, uv).mean() <= 1.2 < g.angle_distortion(V, F, plain).mean()


def test_gauss_newton_stage_descends_the_weighted_model_and_keeps_fixed_vertices():
    # the CG stage: δ vanishes at fixed vertices and lowers the weighted quadratic model
    # ½|W^½(r + Jδ)|² below its value at δ = 0; the halving stage accepts it or a part
    from conformorph.geometry.angle_refinement import (
        _injective_halving,
        _weighted_gauss_newton_step,
    )

    uv, F = _hexagon_fan(centre=(0.2, 0.1))
    beta = corner_angles(np.column_stack([_hexagon_fan()[0], np.zeros(len(uv))]), F)
    free = np.zeros(len(uv), dtype=bool)
    free[0] = True
    E, cross, dot = corner_edge_products(uv, F)
    r = (np.arctan2(cross[:, None], dot) - beta).reshape(-1)
    w = 1.0 / np.maximum(np.abs(r), 1e-3)
    J = _angle_jacobian(E, F, len(uv))
    delta, its = _weighted_gauss_newton_step(J, w, r, free, 5)
    assert its >= 1
    np.testing.assert_array_equal(delta[2:], 0)
    model = lambda d: 0.5 * float(np.sum(w * (r + J @ d) ** 2))  # noqa: E731
    assert model(delta) < model(np.zeros_like(delta))
    before = float(np.abs(r).mean())
    found = _injective_halving(uv, delta.reshape(-1, 2), F, beta, before, 8)
    assert found is not None and found[1] < before
    assert _injective_halving(uv, np.zeros_like(uv), F, beta, before, 0) is None  # no gain
