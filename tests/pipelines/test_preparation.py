"""The preparation step: report, vertex map, carried data, failures (no shared data needed)."""

import numpy as np
import pytest

from conformorph import geometry
from conformorph.pipelines.preparation import (
    PrepareOptions,
    input_landmark_ids,
    preparation_summary,
    prepare_mesh_arrays,
    vertex_values,
)
from tests.meshes import bumpy_disk, eared_disk


def raw_scan() -> tuple[np.ndarray, np.ndarray, dict]:
    """A bumpy disk made scan-like: a hole, a fragment, an unreferenced vertex (row 0),
    duplicate, reversed-duplicate and degenerate faces, and ears."""
    V, F, ears = eared_disk(8)
    r = np.linalg.norm(V[:, :2] - [0.35, 0.1], axis=1)
    hole_faces = np.linalg.norm(V[F].mean(axis=1)[:, :2] - [0.35, 0.1], axis=1) < 0.15
    F = F[~hole_faces]
    inner = np.flatnonzero(r < 0.08)  # vertices left in no face
    n = V.shape[0]
    frag_V = np.array([[3.0, 0, 0], [4, 0, 0], [3, 1, 0], [4, 1, 0]])
    frag_F = np.array([[0, 1, 2], [1, 3, 2]]) + n
    V2 = np.vstack([V, frag_V])
    F2 = np.vstack([F, frag_F, F[:5], F[5:8, ::-1], [[F[9, 0], F[9, 0], F[9, 1]]]])
    # an unused vertex at row 0: every id shifts by one
    V3 = np.vstack([[[9.0, 9, 9]], V2])
    F3 = F2 + 1
    facts = {"hole_vertices": inner + 1, "ears": ears + 1, "fragment": np.arange(n, n + 4) + 1}
    return V3, F3, facts


def test_raw_scan_report_and_vertex_map() -> None:
    V, F, facts = raw_scan()
    p = prepare_mesh_arrays(V, F)
    r = p.report
    assert r["disk"] and r["problem"] is None
    assert r["duplicate_faces"] == 8 and r["degenerate_faces"] == 1
    assert r["unreferenced_vertices"] == 1 + facts["hole_vertices"].size
    assert r["dropped_components"] == [{"vertices": 4, "faces": 2}]
    assert len(r["filled_holes"]) == 1 and r["added_vertices"] > 0
    assert r["removed_ear_vertex_ids"] == sorted(facts["ears"].tolist())
    assert not r["vertex_order_kept"] and not r["unchanged"]
    assert r["input"] == {"vertices": V.shape[0], "faces": F.shape[0]}
    assert r["output"] == {"vertices": p.V.shape[0], "faces": p.F.shape[0]}
    m = p.vertex_map
    kept = m >= 0
    np.testing.assert_array_equal(p.V[kept], V[m[kept]])  # kept vertices unmoved
    assert np.all(np.diff(m[kept]) > 0)  # in the input's relative order
    assert (~kept).sum() == r["added_vertices"]
    gone = np.setdiff1d(np.arange(V.shape[0]), m[kept])
    assert gone.size == r["removed_vertices"]
    assert set(facts["fragment"]) <= set(gone) and 0 in gone
    geometry.validate_mesh(p.V, p.F, require_disk=True)
    s = preparation_summary(r)
    assert s["removed_ear_vertices"] == 2 and "split_vertices" not in s


def test_clean_disk_unchanged() -> None:
    V, F = bumpy_disk(6)
    p = prepare_mesh_arrays(V, F)
    assert p.report["unchanged"] and p.report["vertex_order_kept"] and not p.changed
    np.testing.assert_array_equal(p.vertex_map, np.arange(V.shape[0]))
    np.testing.assert_array_equal(p.F, F)
    assert preparation_summary(p.report) == {}


def test_holes_only_keep_vertex_order() -> None:
    V, F = bumpy_disk(10)
    drop = np.linalg.norm(V[F].mean(axis=1)[:, :2] - [-0.3, 0.2], axis=1) < 0.12
    c = geometry.clean_mesh_elements(V, F[~drop])
    p = prepare_mesh_arrays(c.V, c.F)
    n = c.V.shape[0]
    assert p.report["vertex_order_kept"] and p.report["removed_vertices"] == 0
    np.testing.assert_array_equal(p.vertex_map[:n], np.arange(n))
    np.testing.assert_array_equal(p.V[:n], c.V)
    # the faired patch stays near the true bumpy surface the hole was cut from
    new = p.V[n:]
    d = np.min(np.linalg.norm(new[:, None] - V[None], axis=2), axis=1)
    h = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
    assert d.max() < 1.5 * h


def test_options_turn_steps_off() -> None:
    V, F, _ = raw_scan()
    off = {"keep_largest_component": False, "fill_holes": False, "remove_ears": False}
    p = prepare_mesh_arrays(V, F, PrepareOptions(**off, cut_face=False))
    assert not p.report["disk"] and "components" in p.report["problem"]
    assert "face_cut" not in p.report
    # the face cut, left on, makes the two pieces and the hole a disk around the hole
    p = prepare_mesh_arrays(V, F, PrepareOptions(**off))
    assert p.report["disk"] and "problem" not in p.report["face_cut"]
    geometry.validate_mesh(p.V, p.F, require_disk=True, allow_ears=True)
    with pytest.raises(ValueError, match="max_hole_fraction"):
        PrepareOptions(max_hole_fraction=1.5)


def test_vertex_values_and_landmark_ids() -> None:
    V, F, facts = raw_scan()
    p = prepare_mesh_arrays(V, F)
    values = np.column_stack([V[:, 0], V[:, 1] * 2])  # linear in the position
    values[0] = 0  # the unreferenced row is finite but unused
    out = vertex_values(p, values)
    kept = p.vertex_map >= 0
    np.testing.assert_array_equal(out[kept], values[p.vertex_map[kept]])
    added = ~kept
    # filled like the positions: near the linear field at the new positions
    np.testing.assert_allclose(out[added, 0], p.V[added, 0], atol=0.05)
    ids = input_landmark_ids(p, [int(p.vertex_map[5]), int(facts["fragment"][0]), 0])
    assert ids.tolist() == [5, -1, -1]
    with pytest.raises(ValueError):
        input_landmark_ids(p, [V.shape[0]])
    with pytest.raises(ValueError):
        vertex_values(p, values[:-1])


def test_closed_surface_is_reported_not_a_disk() -> None:
    T = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    closed = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    p = prepare_mesh_arrays(T, closed)
    assert not p.report["disk"] and "closed" in p.report["problem"]
    with pytest.raises(geometry.MeshError):
        prepare_mesh_arrays(T, [[0, 1, 9]])


def test_closed_head_face_cut_with_landmarks() -> None:
    from tests.meshes import closed_head

    V, F = closed_head()
    tip = int(np.argmax(V[:, 2]))
    lm = np.argsort(np.linalg.norm(V - V[tip], axis=1))[:30:5]  # around the nose
    p = prepare_mesh_arrays(V, F, landmark_ids=lm)
    r = p.report
    assert r["disk"] and r["face_cut"]["from_landmarks"] and r["face_cut"]["kept_faces"] > 0
    geometry.validate_mesh(p.V, p.F, require_disk=True)
    rows = input_landmark_ids(p, lm)
    assert (rows >= 0).all()
    np.testing.assert_array_equal(p.V[rows], V[lm])
    assert preparation_summary(r)["face_cut"] == r["face_cut"]
    # without the cut the closed head stays closed, and says so
    q = prepare_mesh_arrays(V, F, PrepareOptions(cut_face=False), landmark_ids=lm)
    assert not q.report["disk"] and "face_cut" not in q.report


def test_face_cut_reason_hand_worked() -> None:
    from conformorph.pipelines.preparation.face_cut import face_cut_reason
    from tests.meshes import closed_head

    V, F = closed_head()
    assert face_cut_reason(V, F, 0.25) == "closed"
    # the flat neck left open: one loop of length 2π·r around the whole head
    open_ = ~np.isclose(V[F][:, :, 1], -0.9).all(axis=1)
    c = geometry.clean_mesh_elements(V, F[open_])
    loop = geometry.boundary_loops(c.F)[0]
    length = np.linalg.norm(c.V[loop] - c.V[np.roll(loop, -1)], axis=1).sum()
    q = length**2 / (4 * np.pi * geometry.triangle_areas(c.V, c.F).sum())
    assert q < 0.25
    assert face_cut_reason(c.V, c.F, 0.25) == (
        f"1 boundary loops short for the area (quotient {q:.3g} < 0.25)"
    )
    assert face_cut_reason(c.V, c.F, q / 2) is None  # a looser threshold takes it as a disk
    # a small hole at the top too: two loops, still short together; a wide one: not short
    for y, short in ((1.05, True), (0.6, False)):
        top = (c.V[c.F][:, :, 1] > y).all(axis=1)
        d = geometry.clean_mesh_elements(c.V, c.F[~top])
        reason = face_cut_reason(d.V, d.F, 0.25)
        assert reason.startswith("2 boundary loops") and ("short" in reason) == short
        assert face_cut_reason(d.V, d.F, 0.0) == "2 boundary loops"
    Vd, Fd = bumpy_disk(6)  # a face-like disk: q near 1
    assert face_cut_reason(Vd, Fd, 0.25) is None
    with pytest.raises(ValueError, match="min_disk_roundness"):
        PrepareOptions(min_disk_roundness=1.5)
    p = prepare_mesh_arrays(c.V, c.F)
    cut = p.report["face_cut"]
    assert p.report["disk"] and "short for the area" in cut["reason"]
    assert cut["closed_loops"] == [loop.size]


def test_close_loops_and_current_rows_hand_worked() -> None:
    from conformorph.pipelines.preparation.face_cut import close_loops, current_rows
    from tests.meshes import closed_head

    # rows of input ids: a split vertex (input 4 at rows 1 and 3) counts by its first row
    src = np.array([7, 4, -1, 4, 0])
    assert current_rows(src, np.array([4, 0, 7, 9])).tolist() == [1, 4, 0]
    V, F = closed_head()
    holes = (V[F][:, :, 1] > 1.05).all(axis=1) | (V[F][:, :, 1] < -0.85).all(axis=1)
    c = geometry.clean_mesh_elements(V, F[~holes])
    sizes = sorted(lp.size for lp in geometry.boundary_loops(c.F))
    src = np.arange(c.V.shape[0])
    W, G, src2, closed = close_loops(c.V, c.F, src)
    assert sorted(closed) == sizes and geometry.mesh_edges(G).boundary.size == 0
    assert W.shape[0] - geometry.mesh_edges(G).edges.shape[0] + G.shape[0] == 2  # a sphere
    np.testing.assert_array_equal(W[: c.V.shape[0]], c.V)
    np.testing.assert_array_equal(src2, np.r_[src, np.full(W.shape[0] - src.size, -1)])
    assert geometry.consistent_orientation(G, W.shape[0]).flipped.sum() == 0
