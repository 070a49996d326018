import numpy as np
import pytest

from conformorph import geometry as g
from conformorph.geometry.conformal_relaxation import (
    _gradient_hessian,
    _max_injective_step,
    _reference_inverses,
    mips_energy,
    symmetric_dirichlet_energy,
)
from tests.meshes import bumpy_disk, disk_grid, random_rotation


def _fan() -> tuple[np.ndarray, np.ndarray]:
    V = np.array([[0.0, 0], [1, 0], [0, 1], [-1, 0], [0, -1]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    return V, F


def test_energy_of_one_triangle_by_hand() -> None:
    # reference: the unit right triangle; map: stretch x by 2. J = diag(2, 1):
    # |J|^2 = 5, det J = 2, energy 5/2 times the area 1/2
    V = np.array([[0.0, 0], [1, 0], [0, 1]])
    F = np.array([[0, 1, 2]])
    Pinv, area = _reference_inverses(V, F)
    assert mips_energy(V * [2.0, 1.0], F, Pinv, area) == pytest.approx(1.25)
    assert mips_energy(V * 3.0, F, Pinv, area) == pytest.approx(1.0)  # a similarity: 2 × area
    assert mips_energy(V * [-1.0, 1.0], F, Pinv, area) == np.inf  # flipped


def test_symmetric_dirichlet_energy_of_one_triangle_by_hand() -> None:
    # J = diag(2, 1): |J|^2 = 5, |J^-1|^2 = 1/4 + 1 = 5/4, sum 6.25 times the area 1/2
    V = np.array([[0.0, 0], [1, 0], [0, 1]])
    F = np.array([[0, 1, 2]])
    Pinv, area = _reference_inverses(V, F)
    assert symmetric_dirichlet_energy(V * [2.0, 1.0], F, Pinv, area) == pytest.approx(3.125)
    c, s_ = np.cos(0.7), np.sin(0.7)
    rotated = V @ np.array([[c, s_], [-s_, c]])
    assert symmetric_dirichlet_energy(rotated, F, Pinv, area) == pytest.approx(2.0)  # 4 × area
    assert symmetric_dirichlet_energy(V * 3.0, F, Pinv, area) > 2.0  # not scale invariant
    assert symmetric_dirichlet_energy(V * [-1.0, 1.0], F, Pinv, area) == np.inf


@pytest.mark.parametrize("energy", ["mips", "symmetric_dirichlet"])
def test_gradient_matches_finite_differences(energy: str) -> None:
    rng = np.random.default_rng(3)
    V = np.array([[0.0, 0], [1, 0], [0.2, 0.9]])
    F = np.array([[0, 1, 2]])
    Pinv, area = _reference_inverses(V, F)
    uv = V @ np.array([[1.3, 0.2], [-0.1, 0.8]]) + 0.05 * rng.standard_normal((3, 2))
    f = mips_energy if energy == "mips" else symmetric_dirichlet_energy
    g_t, _ = _gradient_hessian(uv, F, Pinv, area, energy)  # type: ignore[arg-type]
    h = 1e-6
    fd = np.zeros(6)
    for k in range(6):
        d = np.zeros(6)
        d[k] = h
        fd[k] = (
            f(uv + d.reshape(3, 2), F, Pinv, area) - f(uv - d.reshape(3, 2), F, Pinv, area)
        ) / (2 * h)
    np.testing.assert_allclose(g_t[0], fd, rtol=1e-6, atol=1e-8)


def test_symmetric_dirichlet_relaxation_undoes_a_squeeze() -> None:
    # the fan's centre pushed almost onto an edge: the isometric energy brings it back
    V, F = _fan()
    uv = V.copy()
    uv[0] = [0.45, 0.45]
    out, info = g.conformal_relaxation(V, F, uv, np.array([0]), energy="symmetric_dirichlet")
    np.testing.assert_allclose(out[0], 0.0, atol=1e-8)
    assert info.energy_history[-1] == pytest.approx(4.0)
    assert info.energy_history == sorted(info.energy_history, reverse=True)
    with pytest.raises(ValueError, match="energy must be"):
        g.conformal_relaxation(V, F, uv, np.array([0]), energy="arap")  # type: ignore[arg-type]


def test_max_injective_step_by_hand() -> None:
    # moving vertex 2 of the unit right triangle straight down by d collapses it at t = 1
    uv = np.array([[0.0, 0], [1, 0], [0, 1]])
    d = np.array([[0.0, 0], [0, 0], [0, -1.0]])
    assert _max_injective_step(uv, d, np.array([[0, 1, 2]])) == pytest.approx(1.0)
    assert _max_injective_step(uv, -d, np.array([[0, 1, 2]])) == np.inf


def test_perturbed_fan_returns_to_the_similarity_quadratically() -> None:
    V, F = _fan()
    uv = V.copy()
    uv[0] = [0.3, 0.2]
    out, info = g.conformal_relaxation(V, F, uv, np.array([0]))
    np.testing.assert_allclose(out[0], 0.0, atol=1e-9)
    np.testing.assert_array_equal(out[1:], V[1:])
    assert info.stop_reason == "converged"
    excess = np.array(info.energy_history) - 2.0
    # Newton: the excess energy is (at least) squared step by step near the minimum
    ratios = np.log(excess[2:-1]) / np.log(excess[1:-2])
    assert np.all(excess[:-1] > 0) and ratios.max() > 1.8


def test_flat_disk_relaxes_to_the_identity() -> None:
    V, F = disk_grid(6)
    b = g.boundary_loop(F)
    free = np.setdiff1d(np.arange(len(V)), b)
    rng = np.random.default_rng(1)
    uv = V[:, :2].copy()
    uv[free] += 0.02 * rng.normal(size=(free.size, 2))
    assert not g.flipped_triangles(uv, F).any()
    out, info = g.conformal_relaxation(V, F, uv, free, tol=1e-13)
    np.testing.assert_allclose(out, V[:, :2], atol=1e-7)
    assert info.energy_history[-1] == pytest.approx(2.0, abs=1e-10)


def test_never_flips_and_energy_never_rises() -> None:
    V, F = bumpy_disk(8)
    uv, _ = g.disk_conformal_map(V, F)
    b = g.boundary_loop(F)
    free = np.setdiff1d(np.arange(len(V)), b)
    # a bad but injective start: the map squeezed towards one side
    start = uv.copy()
    start[free, 0] = 0.5 * (start[free, 0] + 0.6 * start[free, 0] ** 2 - 0.3)
    assert not g.flipped_triangles(start, F).any()
    out, info = g.conformal_relaxation(V, F, start, free, max_iterations=30)
    hist = np.array(info.energy_history)
    assert np.all(np.diff(hist) <= 1e-12) and hist[-1] < hist[0]
    assert not g.flipped_triangles(out, F).any()
    np.testing.assert_array_equal(out[b], start[b])
    d0 = g.angle_distortion(V, F, start).mean()
    assert g.angle_distortion(V, F, out).mean() < 0.5 * d0


def test_invariant_to_rigid_motion_and_scale_of_the_reference() -> None:
    V, F = bumpy_disk(6)
    uv, _ = g.disk_conformal_map(V, F)
    free = np.setdiff1d(np.arange(len(V)), g.boundary_loop(F))
    start = uv.copy()
    start[free] *= 0.9
    out, _ = g.conformal_relaxation(V, F, start, free)
    for scale in (1e-3, 1e3):
        W = scale * V @ random_rotation(3).T + [5.0, -2.0, 1.0]
        out2, _ = g.conformal_relaxation(W, F, start, free)
        np.testing.assert_allclose(out2, out, atol=1e-9)


def test_inputs_not_mutated_and_bad_inputs() -> None:
    V, F = _fan()
    uv = V.copy()
    uv[0] = [0.3, 0.2]
    copies = V.copy(), F.copy(), uv.copy()
    g.conformal_relaxation(V, F, uv, np.array([0]))
    for a, c in zip((V, F, uv), copies, strict=True):
        np.testing.assert_array_equal(a, c)
    folded = uv.copy()
    folded[0] = [2.0, 2.0]
    with pytest.raises(ValueError, match="flipped"):
        g.conformal_relaxation(V, F, folded, np.array([0]))
    with pytest.raises(ValueError, match="free vertices"):
        g.conformal_relaxation(V, F, uv, np.array([9]))
    with pytest.raises(ValueError, match="same n"):
        g.conformal_relaxation(V, F, uv[:3], np.array([0]))
    out, info = g.conformal_relaxation(V, F, uv, np.array([], dtype=np.int64))
    assert info.stop_reason == "nothing_free"
    np.testing.assert_array_equal(out, uv)


def test_a_sliding_vertex_moves_only_along_its_line_to_the_energys_minimum() -> None:
    # the unit square split at the bottom midpoint m: triangles (0, m, 3) and (m, 1, 2, 3)
    # fanned; the image squeezes m towards corner 0 along the bottom side. The symmetric
    # Dirichlet energy of the identity is the minimum, so m slides back to x = 0.5 and
    # stays on y = 0.
    V = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0]])
    F = np.array([[0, 4, 3], [4, 1, 2], [4, 2, 3]])
    uv = V.copy()
    uv[4] = [0.1, 0.0]
    out, info = g.conformal_relaxation(
        V,
        F,
        uv,
        np.array([], dtype=np.int64),
        energy="symmetric_dirichlet",
        slide=np.array([4]),
        slide_directions=np.array([[3.0, 0.0]]),
    )
    np.testing.assert_allclose(out[4], [0.5, 0.0], atol=1e-7)
    assert out[4, 1] == 0.0  # exactly on its line
    np.testing.assert_array_equal(out[:4], V[:4])
    assert info.free_vertices == 1
    assert info.energy_history[-1] == pytest.approx(4.0)


def test_slide_arguments_are_checked() -> None:
    V, F = _fan()
    with pytest.raises(ValueError, match="slide must be"):
        g.conformal_relaxation(V, F, V, np.array([0]), slide=np.array([1]))
    with pytest.raises(ValueError, match="not free"):
        g.conformal_relaxation(
            V, F, V, np.array([0]), slide=np.array([0]), slide_directions=np.array([[1.0, 0]])
        )
    with pytest.raises(ValueError, match="non-zero"):
        g.conformal_relaxation(
            V, F, V, np.array([0]), slide=np.array([1]), slide_directions=np.array([[0.0, 0]])
        )


def test_stages_newton_direction_descends_and_line_search_keeps_triangles_positive():
    # the relaxation's stages on the pushed-off fan: the projected Newton step is a
    # descent direction that moves only the free vertex, the line search lowers the
    # energy (Armijo) and stays injective
    from conformorph.geometry.conformal_relaxation import (
        _line_search,
        _newton_direction,
        _reference_inverses,
        _Unknowns,
    )

    V = np.array([[0.0, 0], [1, 0], [0, 1], [-1, 0], [0, -1]])
    F = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    uv = V.copy()
    uv[0] = [0.6, 0.3]
    free = np.array([0])
    u = _Unknowns.of(5, free, np.zeros(0, dtype=np.int64), np.zeros((0, 2)), F)
    assert u.ndof == 2 and u.keep.sum() == 2 * F.shape[0]
    Pinv, area = _reference_inverses(V, F)
    d, slope = _newton_direction(uv, F, Pinv, area, "mips", u)
    assert slope < 0
    np.testing.assert_array_equal(d[1:], 0)
    E = g.mips_energy(uv, F, Pinv, area)
    found = _line_search(uv, d, slope, E, lambda x: g.mips_energy(x, F, Pinv, area), F)
    assert found is not None
    trial, E_new = found
    assert E_new <= E + 1e-4 * slope * 1.0 or E_new < E
    assert not g.flipped_triangles(trial, F).any()
    # no descent along an ascent direction
    assert _line_search(uv, -d, -slope, E, lambda x: g.mips_energy(x, F, Pinv, area), F) is None
