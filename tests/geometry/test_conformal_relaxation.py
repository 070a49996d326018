import numpy as np
import pytest

import geometry as g
from geometry.conformal_relaxation import _max_injective_step, _reference_inverses, mips_energy
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
