"""Tests of geometry.compatible_triangulation."""

import json
from pathlib import Path

import numpy as np
import pytest

from geometry.compatible_triangulation import compatible_triangulation
from geometry.green_lagrange_strain import signed_areas
from geometry.shape_rings import (
    AnchorOutsideShapeError,
    HoleCorrespondenceError,
    ShapeError,
    TooFewAnchorsError,
    distance_to_rings,
    validate_rings,
)

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
SQUARE = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])


def load_pair(a: str, b: str):
    S = validate_rings(json.loads((SHAPES / f"{a}.json").read_text())["rings"])
    T = validate_rings(json.loads((SHAPES / f"{b}.json").read_text())["rings"])
    anchors = np.array(json.loads((SHAPES / f"anchors_{a}__{b}.json").read_text())["anchors"])
    return S, T, anchors


def check(ct, S, T, anchors):
    assert ct.flipped == (0, 0)
    assert np.all(signed_areas(ct.source_V, ct.F) > 0) and np.all(
        signed_areas(ct.target_V, ct.F) > 0
    )
    assert signed_areas(ct.source_V, ct.F).sum() == pytest.approx(S.area, rel=1e-9)
    assert signed_areas(ct.target_V, ct.F).sum() == pytest.approx(T.area, rel=1e-9)
    nb = ct.boundary_vertices
    for shape, X in ((S, ct.source_V), (T, ct.target_V)):
        diag = np.linalg.norm(np.ptp(shape.outer, axis=0))
        assert distance_to_rings(shape, X[:nb]).max() <= 1e-9 * diag
        # every corner of the original ring is kept as a vertex
        d = np.linalg.norm(shape.outer[:, None] - X[None, :nb], axis=2).min(axis=1)
        assert d.max() <= 1e-9 * diag
    assert np.allclose(ct.source_V[ct.anchor_vertices], anchors[:, 0])
    assert np.allclose(ct.target_V[ct.anchor_vertices], anchors[:, 1])


def test_hand_worked_square_to_rectangle():
    S = validate_rings([SQUARE])
    T = validate_rings([SQUARE * [2.0, 1.0]])
    anchors = np.stack([SQUARE, SQUARE * [2.0, 1.0]], axis=1)
    ct = compatible_triangulation(S, T, anchors, triangles_per_shape=20, smoothing_rounds=1)
    check(ct, S, T, anchors)
    # corresponding boundary points are at equal arc-length fractions between the
    # corner anchors, so on the boundary the correspondence is x ↦ (2x, y) exactly
    nb = ct.boundary_vertices
    assert np.allclose(ct.target_V[:nb], ct.source_V[:nb] * [2.0, 1.0], atol=1e-12)


def test_letters_I_to_L_different_vertex_counts():
    S, T, anchors = load_pair("dejavu_bold_I", "dejavu_bold_L")
    assert S.outer.shape[0] != T.outer.shape[0]
    ct = compatible_triangulation(S, T, anchors, smoothing_rounds=1)
    check(ct, S, T, anchors)
    assert min(ct.min_angle) > 1.0
    assert ct.n_triangles < 2000


@pytest.mark.parametrize("s", [1e-3, 1e3])
def test_similarity_of_one_shape_still_gives_valid_meshes(s):
    # Triangle's Steiner points depend on the coordinates, so the meshes are not
    # equal up to the similarity; the guarantees (no flips, corners, anchors) hold.
    S, T, anchors = load_pair("dejavu_bold_I", "dejavu_bold_L")
    th = 0.5
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    S2 = validate_rings([s * S.outer @ R.T])
    a2 = np.stack([s * anchors[:, 0] @ R.T, anchors[:, 1]], 1)
    ct = compatible_triangulation(S2, T, a2, smoothing_rounds=1)
    check(ct, S2, T, a2)


def test_errors():
    S = validate_rings([SQUARE])
    H = validate_rings([SQUARE * 4, (SQUARE + 1)[::-1]])
    anchors = np.stack([SQUARE, SQUARE], axis=1)
    with pytest.raises(HoleCorrespondenceError):
        compatible_triangulation(S, H, anchors)
    with pytest.raises(AnchorOutsideShapeError):
        compatible_triangulation(S, S, anchors + [[0, 0], [5, 5]])
    with pytest.raises(TooFewAnchorsError):
        compatible_triangulation(
            S, S, np.array([[[0.5, 0.5], [0.5, 0.5]], [[0.4, 0.4], [0.4, 0.4]]])
        )
    with pytest.raises(ShapeError, match="orders"):
        compatible_triangulation(S, S, np.stack([SQUARE, SQUARE[[0, 2, 1, 3]]], axis=1))


def test_inputs_not_mutated():
    S, T, anchors = load_pair("dejavu_bold_I", "dejavu_bold_L")
    c = S.outer.copy(), T.outer.copy(), anchors.copy()
    compatible_triangulation(S, T, anchors, smoothing_rounds=0)
    assert (
        np.array_equal(S.outer, c[0])
        and np.array_equal(T.outer, c[1])
        and np.array_equal(anchors, c[2])
    )
