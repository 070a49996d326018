"""The face of a closed surface cut out as a disk (:mod:`conformorph.geometry.face_region`)."""

import numpy as np
import pytest

from conformorph.geometry import (
    FaceRegionError,
    boundary_loops,
    face_direction,
    face_region,
    mesh_edges,
    validate_mesh,
)
from conformorph.geometry.face_region import _clean_disk, _dual_edges
from tests.meshes import closed_cube, closed_head, disk_grid, random_rotation


def _cube_front_landmarks(V: np.ndarray) -> np.ndarray:
    """Five vertices of the cube's +z side, off-centre (no symmetric ties)."""
    front = np.isclose(V[:, 2], 0.5)
    want = [(-1 / 3, -1 / 3), (1 / 3, -1 / 3), (0, 1 / 3), (1 / 3, 1 / 3), (0, 0)]
    return np.array(
        [
            int(np.flatnonzero(front & np.isclose(V[:, 0], x) & np.isclose(V[:, 1], y))[0])
            for x, y in want
        ]
    )


def test_cube_front_side_hand_worked() -> None:
    # the cube's +z side is the face: its border is a 90° crease all round, so the cut
    # follows it exactly: the 2 k² triangles of that side, one loop of 4 k edges
    k = 6
    V, F = closed_cube(k)
    # reach 1.5: the side's corners lie 1.2-1.5 times the landmarks' size from their hull
    # (past the default reach, which is set for faces: the hairline above the brows)
    r = face_region(V, F, _cube_front_landmarks(V), reach=1.5)
    front = np.isclose(V[F][:, :, 2], 0.5).all(axis=1)
    np.testing.assert_array_equal(r.face_mask, front)
    assert r.F.shape[0] == 2 * k * k and r.boundary_edges == 4 * k
    assert r.boundary_crease_deg == pytest.approx(90.0)
    assert r.vertex_map.size == (k + 1) ** 2 and r.from_landmarks
    assert r.filled_islands == 0 and r.bowtie_fans == 0


def _corpus():
    V, F = closed_cube(6)
    yield V, F, _cube_front_landmarks(V)
    H, G = closed_head()
    yield H, G, None
    tip = face_direction(H, G).tip
    near = np.argsort(np.linalg.norm(H - H[tip], axis=1))[1:40:6]  # around the nose
    yield H, G, near
    # an open head: the neck and the top of the skull cut away (two large loops)
    top = (H[G][:, :, 1] > 0.8).all(axis=1) | (H[G][:, :, 1] < -0.8).any(axis=1)
    used = np.unique(G[~top])
    remap = np.full(H.shape[0], -1)
    remap[used] = np.arange(used.size)
    yield H[used], remap[G[~top]], None


@pytest.mark.parametrize("case", range(4))
def test_invariants_disk_subset_landmarks(case: int) -> None:
    V, F, lm = list(_corpus())[case]
    r = face_region(V, F, lm)
    np.testing.assert_array_equal(r.vertex_map, np.unique(F[r.face_mask]))
    remap = np.full(V.shape[0], -1)
    remap[r.vertex_map] = np.arange(r.vertex_map.size)
    np.testing.assert_array_equal(r.F, remap[F[r.face_mask]])  # kept faces, in input order
    validate_mesh(V[r.vertex_map], r.F, require_disk=True, allow_ears=True)
    E = mesh_edges(r.F)
    assert len(boundary_loops(r.F, E)) == 1
    assert r.vertex_map.size - E.edges.shape[0] + r.F.shape[0] == 1
    assert 0 < r.F.shape[0] < F.shape[0]
    if lm is not None:
        assert np.isin(lm, r.vertex_map).all()
    assert r.centre in r.vertex_map


def test_rigid_motion_scale_and_vertex_order() -> None:
    V, F, lm = list(_corpus())[2]
    r = face_region(V, F, lm)
    R = random_rotation(3)
    for W in (V @ R.T + [3.0, -1.0, 2.0], 1e-8 * V, 1e8 * V):
        np.testing.assert_array_equal(face_region(W, F, lm).face_mask, r.face_mask)
    perm = np.random.default_rng(1).permutation(V.shape[0])
    inv = np.argsort(perm)
    p = face_region(V[perm], inv[F], inv[lm])
    np.testing.assert_array_equal(p.face_mask, r.face_mask)
    np.testing.assert_array_equal(np.sort(perm[p.vertex_map]), r.vertex_map)


def test_face_direction_finds_the_nose() -> None:
    V, F = closed_head()
    fd = face_direction(V, F)
    assert fd.tip == int(np.argmax(V[:, 2]))  # the nose bump's apex
    assert fd.direction @ [0.0, 0.0, 1.0] > 0.99
    assert fd.slab_fractions.shape == (6,) and int(np.argmin(fd.slab_fractions)) >= 0
    # turned and moved: the same tip, the direction turned with it
    R = random_rotation(5)
    fr = face_direction(V @ R.T + 1.0, F)
    assert fr.tip == fd.tip and fr.direction @ (R @ fd.direction) > 0.999


def test_islands_filled_to_a_disk() -> None:
    # a ring of kept faces around an unkept centre that does not reach the background:
    # the centre is an island and is filled; the result is the whole inner disk
    V, F = disk_grid(6)
    pairs, _ = _dual_edges(mesh_edges(F), F.shape[0])
    r = np.linalg.norm(V[F].mean(axis=1), axis=1)
    kept = (r > 0.3) & (r < 0.7)
    core = kept & (V[F].mean(axis=1)[:, 0] > 0.4)
    background = r > 0.85
    out, islands, fans = _clean_disk(F, pairs, kept, core, background)
    np.testing.assert_array_equal(out, r < 0.7)
    assert islands == 1 and fans == 0


def test_bad_inputs() -> None:
    V, F = closed_cube(4)
    lm = np.array([0, 1, 2])
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        face_region(V[:, :2], F)
    with pytest.raises(ValueError, match="outside"):
        face_region(V, F + 1000)
    with pytest.raises(ValueError, match="landmark ids"):
        face_region(V, F, [0, 1, 10_000])
    with pytest.raises(ValueError, match="positive"):
        face_region(V, F, lm, reach=0.0)
    with pytest.raises(FaceRegionError, match="at least 3 landmarks"):
        face_region(V, F, [0, 1])
    line = np.flatnonzero(np.isclose(V[:, 1], -0.5) & np.isclose(V[:, 2], -0.5))
    with pytest.raises(FaceRegionError, match="on a line"):
        face_region(V, F, line)
    tet = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(FaceRegionError, match="nothing to cut away"):
        face_region(tet, np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]))


def test_inputs_not_mutated() -> None:
    V, F = closed_head()
    lm = np.array([5, 40, 100, 200])
    copies = V.copy(), F.copy(), lm.copy()
    face_region(V, F, lm)
    face_direction(V, F)
    for a, b in zip((V, F, lm), copies, strict=True):
        np.testing.assert_array_equal(a, b)


def test_pieces_touching_at_a_vertex_joined_by_its_fan() -> None:
    # two core faces that share only a vertex: a bowtie; the vertex's whole fan joins them
    V, F = disk_grid(6)
    pairs, _ = _dual_edges(mesh_edges(F), F.shape[0])
    fan = np.flatnonzero((F == 0).any(axis=1))  # the centre's fan
    a = int(fan[0])
    shares_edge = {int(f) for p in pairs if a in p for f in p}
    b = int(next(f for f in fan if f not in shares_edge))
    core = np.zeros(F.shape[0], dtype=bool)
    core[[a, b]] = True
    background = np.linalg.norm(V[F].mean(axis=1), axis=1) > 0.85
    out, islands, fans = _clean_disk(F, pairs, core.copy(), core, background)
    np.testing.assert_array_equal(np.flatnonzero(out), np.sort(fan))
    assert fans == 1 and islands == 0


def _smooth_head() -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The committed head with no crease (``fixtures/make_smooth_head.py``) and its face's
    68 landmarks; its first ``m`` faces are the face."""
    import json

    from conformorph.pipelines.mesh_io import read_mesh
    from tests.meshes import FIXTURES

    V, F = read_mesh(FIXTURES / "smooth_head.obj")
    meta = json.loads((FIXTURES / "smooth_head.json").read_text())
    return V, F, np.array(meta["landmarks"]), int(meta["face_faces"])


def test_smooth_head_keeps_the_whole_face() -> None:
    # no crease where the back meets the face: the shortest loop around the landmarks'
    # hull would cut the face; the region reaches out to where the face ends instead
    V, F, lm, m = _smooth_head()
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N /= np.linalg.norm(N, axis=1)[:, None]
    pairs, _ = _dual_edges(mesh_edges(F), F.shape[0])
    seam = (pairs[:, 0] < m) != (pairs[:, 1] < m)
    dihedral = np.degrees(np.arccos(np.clip((N[pairs[seam, 0]] * N[pairs[seam, 1]]).sum(1), -1, 1)))
    assert np.median(dihedral) < 15.0  # no seam to follow (a glued-on back: 50°)
    r = face_region(V, F, lm)
    assert r.face_mask[:m].all()  # all of the face
    back = r.face_mask[m:].sum()
    assert back <= 0.25 * (F.shape[0] - m)  # and little of the back
    validate_mesh(V[r.vertex_map], r.F, require_disk=True, allow_ears=True)
    boundary = np.unique(mesh_edges(r.F).boundary)
    assert not np.isin(lm, r.vertex_map[boundary]).any()  # the outline stays off the landmarks
    # the shortest cut (no push; the former reach) cuts into the face
    s = face_region(V, F, lm, reach=1.5, push=0.0)
    assert not s.face_mask[:m].all()


def test_glued_back_still_cut_at_its_seam() -> None:
    # the same face with its back glued on at a crease (the smooth head's face, and a back
    # of straight rings from its outline to a point behind): the cut follows the crease
    from conformorph.geometry import boundary_loop

    V, F, lm, m = _smooth_head()
    Fa = F[:m]
    n = int(Fa.max()) + 1
    b = boundary_loop(Fa, V[:n])
    B = V[b]
    apex = np.array([B[:, 0].mean(), B[:, 1].mean(), B[:, 2].min() - np.ptp(B[:, 0])])
    ring = B + 0.5 * (apex - B)
    ring[:, 2] = B[:, 2] - 0.5 * np.ptp(B[:, 0])  # straight back: a crease at the outline
    W = np.vstack([V[:n], ring, apex[None]])
    r1 = n + np.arange(b.size)
    s0, s1 = np.roll(b, -1), np.roll(r1, -1)
    G = np.vstack(
        [Fa, np.c_[s0, b, r1], np.c_[s0, r1, s1], np.c_[s1, r1, np.full(b.size, W.shape[0] - 1)]]
    )
    r = face_region(W, G, lm)
    np.testing.assert_array_equal(r.face_mask, np.arange(G.shape[0]) < m)
    assert r.boundary_crease_deg > 30.0
