"""Small meshes built in code for the tests (no files needed)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

#: ``../shared/data/faces`` beside the checkout, or ``$CONFORMORPH_SHARED_DATA/faces`` (a
#: worktree elsewhere)
SHARED_FACES = (
    Path(os.environ["CONFORMORPH_SHARED_DATA"]) / "faces"
    if os.environ.get("CONFORMORPH_SHARED_DATA")
    else Path(__file__).resolve().parents[2] / "shared" / "data" / "faces"
)
FIXTURES = Path(__file__).resolve().parent / "fixtures"


def disk_grid(k: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A flat triangulated unit disk: concentric rings, ``k`` rings, planar (z = 0).

    Returns V (n,3), F (m,3) with counter-clockwise faces seen from +z.
    """
    pts = [np.zeros(2)]
    rings = [np.array([0])]
    idx = 1
    for r in range(1, k + 1):
        m = 6 * r
        t = 2 * np.pi * np.arange(m) / m
        pts.extend(np.stack([r / k * np.cos(t), r / k * np.sin(t)], 1))
        rings.append(np.arange(idx, idx + m))
        idx += m
    P = np.asarray(pts)
    from scipy.spatial import Delaunay

    F = Delaunay(P).simplices.astype(np.int64)
    a = P[F[:, 1]] - P[F[:, 0]]
    b = P[F[:, 2]] - P[F[:, 0]]
    ccw = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] > 0
    F[~ccw] = F[~ccw][:, [0, 2, 1]]
    return np.column_stack([P, np.zeros(len(P))]), F


def spherical_cap(k: int = 10, height: float = 0.6) -> tuple[np.ndarray, np.ndarray]:
    """A spherical cap of the unit sphere over the flat disk grid (z up, polar cap)."""
    V, F = disk_grid(k)
    # map the flat disk to the cap by inverse stereographic projection from the south pole,
    # scaled so that the cap reaches polar angle acos(1 - height)
    phi_max = np.arccos(1.0 - height)
    s = np.tan(phi_max / 2)
    x, y = V[:, 0] * s, V[:, 1] * s
    r2 = x**2 + y**2
    P = np.column_stack([2 * x / (1 + r2), 2 * y / (1 + r2), (1 - r2) / (1 + r2)])
    return P, F


def bumpy_disk(k: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A face-like curved disk: a height field over the flat disk grid."""
    V, F = disk_grid(k)
    x, y = V[:, 0], V[:, 1]
    z = 0.4 * np.exp(-4 * (x**2 + y**2)) + 0.1 * np.sin(3 * x) * np.cos(2 * y)
    return np.column_stack([x, y, z]), F


def folded_bumpy_disk(k: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """:func:`bumpy_disk` folded over itself: one interior vertex pushed far through its
    neighbours, so that every disk map of it flips triangles (like the ICT mouth corners)."""
    V, F = bumpy_disk(k)
    i = int(np.argmin(np.hypot(V[:, 0] - 0.3, V[:, 1])))
    V[i, :2] += np.array([0.35, 0.0])
    return V, F


def random_rotation(seed: int = 0) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    return q


def eared_disk(k: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`bumpy_disk` with a chain of two boundary ears on one boundary edge.

    Vertex ``n`` sits in one triangle on edge ``(b0, b1)``, vertex ``n + 1`` in
    one triangle on the new edge ``(b0, n)``: removing ``n + 1`` makes ``n`` an
    ear, so :func:`geometry.remove_boundary_ears` needs two rounds. Returns
    V (n+2, 3), F (m+2, 3) and the ear vertices ``[n, n + 1]``.
    """
    from conformorph.geometry.boundary_loop import boundary_loop

    V, F = bumpy_disk(k)
    b = boundary_loop(F)
    n = len(V)
    out = 0.5 * (V[b[0]] + V[b[1]])
    e1 = out * [1.3, 1.3, 1.0]
    e2 = 0.5 * (V[b[0]] + e1) * [1.25, 1.25, 1.0]
    V2 = np.vstack([V, e1, e2])
    F2 = np.vstack([F, [[b[1], b[0], n]], [[n, b[0], n + 1]]])
    return V2, F2, np.array([n, n + 1])


def _outward(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``F`` with every face turned to face away from the origin (star-shaped closed meshes)."""
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    inward = (n * V[F].mean(axis=1)).sum(axis=1) < 0
    F = F.copy()
    F[inward] = F[inward][:, ::-1]
    return F


def closed_cube(k: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """The surface of the cube [-1/2, 1/2]³, each side a k × k grid of split squares (outward)."""
    t = np.linspace(-0.5, 0.5, k + 1)
    a, b = (x.ravel() for x in np.meshgrid(t, t, indexing="ij"))
    q = np.arange(k * (k + 1)).reshape(k, k + 1)[:, :k].ravel()  # lower-left corners
    quads = np.c_[q, q + k + 1, q + k + 2, q + 1]
    tri = np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    pts, faces = [], []
    for axis in range(3):
        for side in (-0.5, 0.5):
            P = np.insert(np.c_[a, b], axis, side, axis=1)
            faces.append(tri + sum(p.shape[0] for p in pts))
            pts.append(P)
    V, inv = np.unique(np.round(np.vstack(pts), 12), axis=0, return_inverse=True)
    return V, _outward(V, inv.reshape(-1)[np.vstack(faces)])


def closed_head(rings: int = 16, sectors: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """A closed genus-0 head: an ellipsoid with a nose bump toward +z and a flat neck cut at
    the bottom (-y); latitude rings around the y axis, a vertex at each pole (outward)."""
    theta = np.linspace(0, np.pi, rings + 2)[1:-1]  # from +y (top) down to -y
    phi = np.linspace(0, 2 * np.pi, sectors, endpoint=False)
    T, P = np.meshgrid(theta, phi, indexing="ij")
    d = np.c_[(np.sin(T) * np.sin(P)).ravel(), np.cos(T).ravel(), (np.sin(T) * np.cos(P)).ravel()]
    d = np.vstack([[0.0, 1.0, 0.0], d, [0.0, -1.0, 0.0]])
    nose = 0.3 * np.exp(-((d[:, 0] ** 2 + (d[:, 1] + 0.1) ** 2) / 0.03)) * (d[:, 2] > 0)
    V = d * np.array([0.75, 1.1, 0.9]) + nose[:, None] * [0.0, 0.0, 1.0]
    V[:, 1] = np.maximum(V[:, 1], -0.9)  # the neck, cut flat
    ring = lambda i: 1 + i * sectors + np.arange(sectors)  # noqa: E731
    F = [np.c_[np.zeros(sectors, np.int64), ring(0), np.roll(ring(0), -1)]]
    for i in range(rings - 1):
        a, b = ring(i), ring(i + 1)
        F += [np.c_[a, b, np.roll(b, -1)], np.c_[a, np.roll(b, -1), np.roll(a, -1)]]
    south = 1 + rings * sectors
    F.append(np.c_[np.full(sectors, south), np.roll(ring(rings - 1), -1), ring(rings - 1)])
    F = np.vstack(F).astype(np.int64)
    return V, _outward(V - V.mean(axis=0), F)
