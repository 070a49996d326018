"""Tests of conformorph.geometry.compatible_map_relaxation (the target of a compatible map relaxed)."""

import numpy as np
import pytest
from scipy.spatial import Delaunay

from conformorph.geometry.compatible_map_relaxation import relaxed_target
from conformorph.geometry.compatible_triangulation import CompatibleTriangulation
from conformorph.geometry.conformal_relaxation import symmetric_dirichlet_energy
from conformorph.geometry.flip_repair import _areas
from conformorph.geometry.map_stretch import map_stretch
from conformorph.geometry.mesh_edges import mesh_boundary_vertices


def _grid_ct(k=7, seed=0, push=0.4):
    """A jittered k×k grid on the unit square (Delaunay) as source; as target the same
    triangles moved by p + push · sin(πx) sin(πy) / π · (1, 1), a bijection of the
    square onto itself that fixes its boundary (Jacobian determinant ≥ 1 − 2 push)."""
    rng = np.random.default_rng(seed)
    g = np.linspace(0.0, 1.0, k)
    P = np.array([[x, y] for y in g for x in g])
    inner = (P > 0).all(axis=1) & (P < 1).all(axis=1)
    P[inner] += rng.uniform(-0.2, 0.2, size=(int(inner.sum()), 2)) / (k - 1)
    F = Delaunay(P).simplices.astype(np.int64)
    neg = _areas(P, F) < 0
    F[neg] = F[neg][:, [0, 2, 1]]
    Q = P.copy()
    bump = np.sin(np.pi * P[:, 0]) * np.sin(np.pi * P[:, 1]) / np.pi
    Q += push * bump[:, None] * np.array([1.0, 1.0])
    assert np.all(_areas(Q, F) > 0)
    corner = np.flatnonzero(~inner)[:1]
    ct = CompatibleTriangulation(P, Q, F, corner, int((~inner).sum()), (0, 0), (1.0, 1.0), 0, 0)
    return ct, ~inner


def _energy(ct):
    scale = np.sqrt(_areas(ct.target_V, ct.F).sum() / _areas(ct.source_V, ct.F).sum())
    from conformorph.geometry.conformal_relaxation import _reference_inverses

    Pinv, area = _reference_inverses(ct.source_V * scale, ct.F)
    return symmetric_dirichlet_energy(ct.target_V, ct.F, Pinv, area)


def test_boundary_vertices_of_a_hand_worked_strip():
    # two triangles sharing the diagonal 0-2: every vertex is on the boundary;
    # a fan of four around vertex 4: only the centre is inside
    assert mesh_boundary_vertices(np.array([[0, 1, 2], [0, 2, 3]]), 4).all()
    F = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    assert mesh_boundary_vertices(F, 6).tolist() == [True, True, True, True, False, False]


@pytest.mark.parametrize("bad", [np.array([[0, 1]]), np.array([[0, 1, 5]]), np.array([[-1, 1, 2]])])
def test_boundary_vertices_refuse_bad_faces(bad):
    with pytest.raises(ValueError):
        mesh_boundary_vertices(bad, 4)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_relaxation_lowers_distortion_and_keeps_what_is_fixed(seed):
    ct, boundary = _grid_ct(seed=seed)
    S0, T0, F0 = ct.source_V.copy(), ct.target_V.copy(), ct.F.copy()
    out, info = relaxed_target(ct)
    # inputs untouched, source and triangles and the boundary unchanged
    assert np.array_equal(ct.source_V, S0) and np.array_equal(ct.target_V, T0)
    assert np.array_equal(out.source_V, S0) and np.array_equal(out.F, F0)
    assert np.array_equal(out.target_V[boundary], T0[boundary])
    # still a valid mesh of the same square, less distorted
    assert out.flipped == (0, 0) and np.all(_areas(out.target_V, out.F) > 0)
    assert _areas(out.target_V, out.F).sum() == pytest.approx(1.0)
    # the energy is ≥ 4 per unit area, 4 exactly for a rotation on every triangle; the
    # default tolerance stops within 1e-3 of a step's relative decrease
    assert _energy(ct) > 4.1 and _energy(out) - 4.0 < 0.1 * (_energy(ct) - 4.0)
    assert map_stretch(S0, out.target_V, F0).max_anisotropy < map_stretch(S0, T0, F0).max_anisotropy
    assert info.stop_reason == "converged" and info.energy_history[-1] < info.energy_history[0]
    # converged tightly: the identity (the optimum here, same boundary)
    tight, _ = relaxed_target(ct, tol=1e-12)
    assert _energy(tight) == pytest.approx(4.0, abs=1e-6)
    assert np.abs(tight.target_V - S0).max() < 1e-4


def test_anchor_vertices_stay():
    ct, boundary = _grid_ct()
    inner = np.flatnonzero(~boundary)
    anchors = np.r_[ct.anchor_vertices, inner[:3]]
    from dataclasses import replace

    out, _ = relaxed_target(replace(ct, anchor_vertices=anchors))
    assert np.array_equal(out.target_V[inner[:3]], ct.target_V[inner[:3]])
    assert not np.array_equal(out.target_V[inner[3:]], ct.target_V[inner[3:]])


@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_scale_and_rigid_motion_invariance(scale):
    ct, _ = _grid_ct(seed=3)
    from dataclasses import replace

    ref, _ = relaxed_target(ct)
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s], [s, c]])
    moved = replace(ct, target_V=scale * ct.target_V @ R.T + np.array([3.0, -2.0]) * scale)
    out, _ = relaxed_target(moved)
    back = (out.target_V / scale - np.array([3.0, -2.0])) @ R
    assert np.allclose(back, ref.target_V, atol=1e-6)


def test_refuses_flipped_and_negative_iterations():
    ct, _ = _grid_ct()
    from dataclasses import replace

    with pytest.raises(ValueError, match="flipped"):
        relaxed_target(replace(ct, flipped=(0, 2)))
    with pytest.raises(ValueError, match="max_iterations"):
        relaxed_target(ct, max_iterations=-1)
