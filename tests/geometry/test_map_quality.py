import json

import numpy as np
import pytest

from conformorph.geometry.boundary_loop import boundary_loop
from conformorph.geometry.map_quality import (
    boundary_isoperimetric_ratio,
    histogram,
    map_quality,
)
from tests.meshes import bumpy_disk, disk_grid

TRI_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
TRI_F = np.array([[0, 1, 2]])


def test_one_triangle_stretch_by_hand():
    # uv = (2x, y): the right angle at 0 stays, the 45° angles become atan(1/2) and atan(2)
    uv = TRI_V[:, :2] * [2.0, 1.0]
    q = map_quality(TRI_V, TRI_F, uv)
    d = np.degrees(np.arctan(2.0)) - 45.0
    assert q.angle_distortion_max == pytest.approx(d)
    assert q.angle_distortion_mean == pytest.approx(2 * d / 3)
    assert q.beltrami_max == pytest.approx(1 / 3)
    assert q.flipped == 0
    assert q.angle_histogram.counts.sum() == 3
    assert q.angle_histogram.counts[0] == 1 and q.angle_histogram.counts[int(d)] == 2
    assert np.isnan(q.boundary_circle_error)


def test_flip_counted_and_mu_overflows():
    uv = TRI_V[:, :2] * [1.0, -1.0]
    q = map_quality(TRI_V, TRI_F, uv)
    assert q.flipped == 1
    assert q.beltrami_histogram.above == 1 and q.beltrami_histogram.counts.sum() == 0


def test_histogram_counts_and_out_of_range():
    h = histogram(np.array([-1.0, 0.0, 0.5, 1.0, 2.0, np.nan]), np.array([0.0, 1.0, 2.0]))
    assert h.counts.tolist() == [2, 2] and h.below == 1 and h.above == 1
    with pytest.raises(ValueError):
        histogram(np.zeros(3), np.array([1.0, 0.0]))


def test_isoperimetric_ratio_of_circle_and_square():
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    circ = np.column_stack([np.cos(t), np.sin(t)])
    assert boundary_isoperimetric_ratio(circ, np.arange(2000)) == pytest.approx(1, abs=1e-5)
    sq = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    assert boundary_isoperimetric_ratio(sq, np.arange(4)) == pytest.approx(np.pi / 4)


def test_identity_map_of_flat_disk_and_json():
    V, F = disk_grid(5)
    b = boundary_loop(F)
    q = map_quality(V, F, V[:, :2], b)
    assert q.angle_distortion_max < 1e-10 and q.beltrami_max < 1e-12 and q.flipped == 0
    assert q.boundary_circle_error < 1e-15
    d = json.loads(json.dumps(q.to_dict()))
    assert d["flipped"] == 0 and len(d["angle_histogram"]["counts"]) == 180
    assert d["n_faces"] == F.shape[0]


def test_inputs_not_mutated_and_bad_shapes():
    V, F = bumpy_disk(4)
    uv = V[:, :2].copy()
    copies = [x.copy() for x in (V, F, uv)]
    q = map_quality(V, F, uv, boundary_loop(F))
    assert q.angle_histogram.counts.sum() == 3 * F.shape[0]
    for x, y in zip((V, F, uv), copies, strict=True):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError):
        map_quality(V, F, uv[:-1])
    with pytest.raises(ValueError):
        map_quality(V, F[:0], uv)
