"""conformorph.geometry.outline_features: multi-scale turning-angle extrema of a closed ring."""

import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.geometry.outline_features import (
    FeatureOptions,
    outline_features,
    ring_arc_positions,
    ring_points_at,
    turning_angles,
)

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"


def _outer(name: str) -> np.ndarray:
    return np.array(json.loads((SHAPES / f"{name}.json").read_text())["rings"][0], dtype=float)


def _densify(ring: np.ndarray, per_edge: int) -> tuple[np.ndarray, np.ndarray]:
    """Each edge split into ``per_edge`` pieces; also the index of each original vertex."""
    nxt = np.roll(ring, -1, axis=0)
    t = np.arange(per_edge)[:, None] / per_edge
    pts = [ring[i] + t * (nxt[i] - ring[i]) for i in range(len(ring))]
    return np.vstack(pts), np.arange(len(ring)) * per_edge


def test_rectangle_by_hand():
    """A 2 x 1 rectangle: its four corners turn by pi/2 (saliency 1/2), at arcs 0, 1/3, 1/2, 5/6."""
    f = outline_features([[0, 0], [2, 0], [2, 1], [0, 1]])
    assert f.index.tolist() == [0, 1, 2, 3]
    np.testing.assert_allclose(f.turning, np.pi / 2)
    np.testing.assert_allclose(f.saliency, 0.5)
    np.testing.assert_allclose(f.arc, [0, 1 / 3, 1 / 2, 5 / 6])


def test_arc_positions_and_points_by_hand():
    s, perimeter = ring_arc_positions([[0, 0], [2, 0], [2, 1], [0, 1]])
    assert perimeter == 6.0
    np.testing.assert_allclose(s, [0, 2, 3, 5])
    np.testing.assert_allclose(
        ring_points_at([[0, 0], [2, 0], [2, 1], [0, 1]], [0.25, 1.25, -0.25]),
        [[1.5, 0], [1.5, 0], [0.5, 1]],
    )


def test_concave_corner_turns_right():
    """An L: the inner corner turns by -pi/2 on a counter-clockwise ring."""
    L = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
    theta = turning_angles(L, 0.02)
    assert theta[3] == pytest.approx(-np.pi / 2)
    np.testing.assert_allclose(np.delete(theta, 3), np.pi / 2)


def test_circle_has_no_features_at_any_density():
    for n in (24, 100, 1000):
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        assert outline_features(np.column_stack([np.cos(t), np.sin(t)])).index.size == 0


@pytest.mark.parametrize(
    "name", ["flubber_star", "dejavu_bold_L", "dejavu_bold_T", "dejavu_bold_A"]
)
def test_robust_to_sampling_density(name):
    """Splitting every edge into 5 leaves the features on the original vertices.

    The saliency may differ a little: a coarse-scale extremum on a short edge
    (a stroke end) sits between two vertices of the sparse outline.
    """
    ring = _outer(name)
    f = outline_features(ring)
    dense, where = _densify(ring, 5)
    g = outline_features(dense)
    assert g.index.tolist() == where[f.index].tolist()
    np.testing.assert_allclose(g.saliency, f.saliency, atol=0.05)


@pytest.mark.parametrize("name", ["flubber_horse", "dejavu_bold_S", "figure_stand"])
def test_invariant_to_similarity_and_start(name):
    ring = _outer(name)
    f = outline_features(ring)
    c, s = np.cos(0.7), np.sin(0.7)
    for scale in (1e-8, 1e8):
        moved = scale * ring @ np.array([[c, s], [-s, c]]) + [3.0, -4.0]
        g = outline_features(moved)
        assert g.index.tolist() == f.index.tolist()
        np.testing.assert_allclose(g.saliency, f.saliency, atol=1e-6)  # 4-digit input
    k = 17
    g = outline_features(np.roll(ring, -k, axis=0))
    assert sorted(((g.index + k) % len(ring)).tolist()) == f.index.tolist()


def test_reversed_ring_flips_the_turning_sign():
    ring = _outer("dejavu_bold_U")
    f = outline_features(ring)
    g = outline_features(ring[::-1])
    n = len(ring)
    assert sorted((n - 1 - g.index).tolist()) == f.index.tolist()
    order = np.argsort(n - 1 - g.index)
    np.testing.assert_allclose(g.turning[order], -f.turning, atol=1e-9)


def test_separation_and_thresholds():
    ring = _outer("flubber_horse")
    f = outline_features(ring)
    d = np.abs(f.arc[:, None] - f.arc[None, :])
    d = np.minimum(d, 1 - d) + np.eye(len(f.arc))
    assert d.min() > FeatureOptions().min_separation
    assert np.all(f.saliency * np.pi > FeatureOptions().min_turning)
    assert np.all(np.diff(f.index) > 0)
    fewer = outline_features(ring, options=FeatureOptions(min_turning=1.5))
    assert 0 < fewer.index.size < f.index.size
    assert np.all(fewer.saliency * np.pi > 1.5)


def test_input_not_mutated_and_errors():
    ring = _outer("dejavu_bold_C")
    before = ring.copy()
    outline_features(ring)
    np.testing.assert_array_equal(ring, before)
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        outline_features([[0, 0], [1, 0]])
    with pytest.raises(ValueError, match="finite"):
        outline_features([[0, 0], [1, np.nan], [0, 1]])
    with pytest.raises(ValueError, match="scale"):
        turning_angles(ring, 0.5)
