import numpy as np
import pytest

from conformorph import geometry as g
from tests.meshes import bumpy_disk, eared_disk

SQUARE_F = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 2]])  # ear 4 on edge (1, 2)
SQUARE_UV = np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])


def test_extend_uv_to_ears_by_hand():
    # the ear of edge (1, 2) goes to the middle of the arc from 90° to 180°
    uv = g.extend_uv_to_ears(SQUARE_UV, SQUARE_F, np.arange(4))
    np.testing.assert_allclose(uv[4], [-np.sqrt(0.5), np.sqrt(0.5)], atol=1e-15)
    np.testing.assert_array_equal(uv[:4], SQUARE_UV)
    assert not g.flipped_triangles(uv, SQUARE_F).any()


def test_extend_uv_to_ears_takes_the_far_arc_when_the_near_one_is_wrong():
    # faces clockwise in this uv: the ear must go to the side that keeps them clockwise,
    # i.e. the conjugate of the counter-clockwise answer
    uv = g.extend_uv_to_ears(SQUARE_UV * [1, -1], SQUARE_F, np.arange(4))
    np.testing.assert_allclose(uv[4], [-np.sqrt(0.5), -np.sqrt(0.5)], atol=1e-15)
    # an ear whose neighbours are antipodal (edge (0, 2), a diameter) still lands outside
    F = np.array([[0, 1, 2], [0, 2, 3]])  # face 1's ear 3 lies below the diameter
    uv = g.extend_uv_to_ears(np.array([[1.0, 0], [0, 1], [-1, 0]]), F, np.arange(3))
    np.testing.assert_allclose(uv[3], [0, -1], atol=1e-15)
    assert not g.flipped_triangles(uv, F).any()


def test_two_rounds_of_ears_give_a_complete_unfolded_disk_map():
    V, F, ears = eared_disk()
    V0, F0 = V.copy(), F.copy()
    V2, F2, kept = g.remove_boundary_ears(V, F)
    np.testing.assert_array_equal(np.setdiff1d(np.arange(len(V)), kept), ears)  # both rounds
    uv, _ = g.disk_conformal_map(V2, F2)
    full = g.extend_uv_to_ears(uv, F, kept)
    assert full.shape == (len(V), 2)
    np.testing.assert_array_equal(full[kept], uv)  # the map is unchanged where it was computed
    b = g.boundary_loop(F)
    assert set(ears) <= set(b.tolist())
    np.testing.assert_allclose(np.hypot(*full[b].T), 1.0, atol=1e-12)
    assert not g.flipped_triangles(full, F).any()  # a bijective map of the whole input
    # invariant: rotating and reflecting the map rotates and reflects the placed ears
    R = np.array([[0.6, -0.8], [0.8, 0.6]]) @ np.diag([1.0, -1.0])
    np.testing.assert_allclose(g.extend_uv_to_ears(uv @ R.T, F, kept), full @ R.T, atol=1e-12)
    # inputs untouched
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)


def test_extend_uv_to_ears_bad_input():
    with pytest.raises(ValueError, match="one row per kept vertex"):
        g.extend_uv_to_ears(SQUARE_UV[:3], SQUARE_F, np.arange(4))
    with pytest.raises(ValueError, match="increasing"):
        g.extend_uv_to_ears(SQUARE_UV, SQUARE_F, np.array([0, 2, 1, 3]))
    # removed vertices that no face peels off one at a time: not from remove_boundary_ears
    with pytest.raises(ValueError, match="4 removed vertices cannot be placed"):
        g.extend_uv_to_ears(SQUARE_UV[:1], SQUARE_F, np.array([0]))


def test_repairs_check_the_faces_before_indexing_with_them():
    V, F = bumpy_disk(3)
    F_out = F.copy()
    F_out[2, 1] = len(V) + 4
    for repair in (g.remove_boundary_ears, g.fill_holes):
        with pytest.raises(g.FaceIndexOutOfRangeError, match="face 2"):
            repair(V, F_out)
        # an unreferenced vertex is an error, not silently dropped
        with pytest.raises(g.UnreferencedVertexError, match=str(len(V))):
            repair(np.vstack([V, [[5.0, 5, 5]]]), F)
