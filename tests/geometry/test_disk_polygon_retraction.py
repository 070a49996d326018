import numpy as np
import pytest

import geometry as g
from tests.meshes import disk_grid


def _polygon(k: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * np.pi, k))
    return np.column_stack([np.cos(t), np.sin(t)])


def _inside_convex(points: np.ndarray, B: np.ndarray, tol: float = 1e-12) -> np.ndarray:
    B = B[np.argsort(np.arctan2(B[:, 1], B[:, 0]))]
    e = np.roll(B, -1, axis=0) - B
    rel = points[:, None, :] - B[None, :, :]
    cross = e[None, :, 0] * rel[:, :, 1] - e[None, :, 1] * rel[:, :, 0]
    return np.all(cross >= -tol, axis=1)


def test_square_by_hand() -> None:
    sq = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])
    pts = np.array([[1.0, 0], [0.5**0.5, 0.5**0.5], [0.0, 0.0], [0, -1.0]])
    out = g.retract_to_boundary_polygon(pts, sq)
    np.testing.assert_allclose(out, [[1, 0], [0.5, 0.5], [0, 0], [0, -1]], atol=1e-12)


def test_outputs_lie_in_the_polygon_and_the_core_does_not_move() -> None:
    B = _polygon(60)
    rng = np.random.default_rng(2)
    r = np.sqrt(rng.uniform(0, 1, 4000))
    t = rng.uniform(0, 2 * np.pi, 4000)
    pts = np.column_stack([r * np.cos(t), r * np.sin(t)])
    pts[:50] /= np.hypot(*pts[:50].T)[:, None]  # some exactly on the circle
    out = g.retract_to_boundary_polygon(pts, B)
    assert _inside_convex(out, B, tol=1e-12).all()
    # the circle goes onto the polygon's boundary
    d = np.hypot(*out[:50].T)
    assert np.all(d <= 1 + 1e-15)
    # only a thin band moves; the move is radial and outward points stay outward
    moved = np.linalg.norm(out - pts, axis=1) > 0
    assert np.hypot(*pts[moved].T).min() > 0.5
    ang_in, ang_out = np.arctan2(pts[:, 1], pts[:, 0]), np.arctan2(out[:, 1], out[:, 0])
    np.testing.assert_allclose(np.angle(np.exp(1j * (ang_in - ang_out))), 0, atol=1e-12)


def test_monotone_along_rays_keeps_a_fine_mesh_unfolded() -> None:
    # a fine mesh of the rim, pushed into the chord–arc slivers of a coarse polygon
    V, F = disk_grid(40)
    uv = V[:, :2]
    B = _polygon(24, seed=5)
    out = g.retract_to_boundary_polygon(uv, B)
    assert not g.flipped_triangles(out, F).any()
    # snapping to the nearest polygon point instead folds (what this replaces)
    snapped = uv.copy()
    outside = ~_inside_convex(uv, B)
    loc = g.PointLocator(*_fan(B)).locate(uv[outside])
    snapped[outside] = loc.interpolate(_fan(B)[1], _fan(B)[0])
    assert g.flipped_triangles(snapped, F).sum() > 0


def _fan(B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    B = B[np.argsort(np.arctan2(B[:, 1], B[:, 0]))]
    k = B.shape[0]
    P = np.vstack([[0.0, 0.0], B])
    F = np.array([[0, 1 + j, 1 + (j + 1) % k] for j in range(k)])
    return P, F


def test_displacement_falls_with_refinement_like_the_sagitta() -> None:
    t = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    circle = np.column_stack([np.cos(t), np.sin(t)])
    moves = []
    for k in (16, 32, 64, 128):
        B = np.column_stack(
            [np.cos(2 * np.pi * np.arange(k) / k), np.sin(2 * np.pi * np.arange(k) / k)]
        )
        moves.append(
            np.linalg.norm(g.retract_to_boundary_polygon(circle, B) - circle, axis=1).max()
        )
    order = np.log2(np.array(moves[:-1]) / np.array(moves[1:]))
    np.testing.assert_allclose(order, 2.0, atol=0.05)  # sagitta 1 − cos(π/k) ~ (π/k)²/2


def test_inputs_not_mutated_and_bad_inputs() -> None:
    B = _polygon(10)
    pts = np.array([[0.99, 0.0], [0.0, 0.2]])
    keep = pts.copy()
    g.retract_to_boundary_polygon(pts, B)
    np.testing.assert_array_equal(pts, keep)
    with pytest.raises(ValueError, match="contain the origin"):
        g.retract_to_boundary_polygon(pts, np.array([[1.0, 0], [0.9**0.5, 0.1**0.5], [0.8, 0.6]]))
    with pytest.raises(ValueError, match="shape"):
        g.retract_to_boundary_polygon(pts[:, :1], B)
    with pytest.raises(ValueError, match="band"):
        g.retract_to_boundary_polygon(pts, B, band=0.5)
