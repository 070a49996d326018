"""Tests of conformorph.geometry.detail_transfer: dense points carried by a coarse mesh."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.geometry.detail_transfer import (
    detail_embedding,
    transferred_frames,
    transferred_points,
)
from tests.meshes import bumpy_disk


def _rotation(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_one_triangle_by_hand():
    V = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0]])
    F = np.array([[0, 1, 2]])
    P = np.array([[0.5, 0.5, 0.3]])  # above the triangle: offset 0.3 along +z
    emb = detail_embedding(P, V, F)
    np.testing.assert_allclose(emb.barycentric, [[0.5, 0.25, 0.25]])
    np.testing.assert_allclose(emb.offset, [[0.0, 0.0, 0.3 / 2.0]])  # σ = √(2·2) = 2
    np.testing.assert_allclose(transferred_points(emb, V, F), P)
    # the triangle scaled by 3 and turned over (z → −z by a half turn about x)
    R = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]])
    np.testing.assert_allclose(transferred_points(emb, 3 * V @ R.T, F), 3 * P @ R.T)


def test_rest_pose_exact_and_similarities_followed():
    V, F = bumpy_disk()
    rng = np.random.default_rng(0)
    P = V[rng.choice(V.shape[0], 50, replace=False)] + rng.normal(0, 1e-3, (50, 3))
    emb = detail_embedding(P, V, F)
    np.testing.assert_allclose(transferred_points(emb, V, F), P, atol=1e-12)
    for s, angle, t in (
        (1.0, 0.7, [1.0, 2.0, 3.0]),
        (1e-3, -2.0, [0, 0, 0]),
        (1e3, 0.1, [5, 0, 0]),
    ):
        W = s * V @ _rotation(angle).T + t
        want = s * P @ _rotation(angle).T + t
        np.testing.assert_allclose(transferred_points(emb, W, F), want, atol=1e-9 * max(s, 1))


def test_inputs_checked_and_not_mutated():
    V, F = bumpy_disk()
    P = V[:5].copy()
    V0, F0, P0 = V.copy(), F.copy(), P.copy()
    emb = detail_embedding(P, V, F)
    transferred_points(emb, V, F)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)
    np.testing.assert_array_equal(P, P0)
    with pytest.raises(ValueError, match="face indices"):
        detail_embedding(P, V, F + V.shape[0])
    with pytest.raises(ValueError, match="finite"):
        detail_embedding(np.full((2, 3), np.nan), V, F)


def test_all_frames_at_once_match_each_frame():
    """transferred_frames == transferred_points per frame (a rest frame, a similarity,
    a non-rigid bend), and the hand-worked triangle through it."""
    V, F = bumpy_disk()
    rng = np.random.default_rng(1)
    P = V[rng.choice(V.shape[0], 80, replace=False)] + rng.normal(0, 1e-3, (80, 3))
    emb = detail_embedding(P, V, F)
    bend = V + 0.1 * np.sin(2.0 * V[:, [1, 2, 0]])
    X = np.stack([V, 2.0 * V @ _rotation(0.4).T + [1.0, 0.0, 0.0], bend])
    got = transferred_frames(emb, X, F)
    assert got.shape == (3, 80, 3)
    for k in range(3):
        np.testing.assert_allclose(got[k], transferred_points(emb, X[k], F), atol=1e-12)
    np.testing.assert_allclose(got[0], P, atol=1e-12)
    tri = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0]])
    one = detail_embedding(np.array([[0.5, 0.5, 0.3]]), tri, np.array([[0, 1, 2]]))
    R = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]])
    np.testing.assert_allclose(
        transferred_frames(one, (3 * tri @ R.T)[None], np.array([[0, 1, 2]]))[0],
        3 * np.array([[0.5, 0.5, 0.3]]) @ R.T,
    )
    with pytest.raises(ValueError, match="non-finite"):
        transferred_frames(emb, np.stack([V, np.full_like(V, np.nan)]), F)
