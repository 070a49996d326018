import json
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.landmarks_io import (
    DuplicateLandmarkError,
    LandmarkCountMismatchError,
    LandmarkFormatError,
    LandmarkIndexError,
    LandmarkTooFarError,
    TooFewLandmarksError,
    parse_landmark_json,
    read_landmark_file,
    resolve_landmarks,
)

from .face_fixtures import face_mesh

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "faces"


def test_vertex_indices_resolve_to_the_vertices():
    V, F, lm = face_mesh()
    s = resolve_landmarks(lm, V, F)
    np.testing.assert_allclose(s.points, V[lm], atol=1e-15)
    assert (s.snap_distance == 0).all() and s.vertex.tolist() == lm
    np.testing.assert_allclose(s.barycentric.sum(axis=1), 1.0)


def test_points_are_snapped_and_distance_reported():
    V, F, lm = face_mesh()
    pts = V[lm[:3]] + [0.0, 0.0, 0.01]
    s = resolve_landmarks([p.tolist() for p in pts] + lm[3:], V, F)
    assert np.all(s.snap_distance[:3] > 0) and np.all(s.snap_distance[:3] <= 0.01 + 1e-12)
    assert np.all(np.abs(s.points[:3] - V[lm[:3]]).max(axis=1) < 0.02)
    assert (s.vertex[:3] == -1).all()


def test_named_errors():
    V, F, lm = face_mesh()
    with pytest.raises(LandmarkIndexError, match="out of range"):
        resolve_landmarks(lm[:-1] + [V.shape[0]], V, F)
    # numbered as a person reads them (from 1), the JSON place beside (from 0)
    k = len(lm)
    with pytest.raises(
        LandmarkIndexError, match=rf"^mesh 2, landmark {k} \(landmarks\[1\]\[{k - 1}\]\)"
    ):
        resolve_landmarks(lm[:-1] + [V.shape[0]], V, F, mesh_index=1)
    with pytest.raises(DuplicateLandmarkError):
        resolve_landmarks(lm[:-1] + [lm[0]], V, F)
    with pytest.raises(TooFewLandmarksError):
        resolve_landmarks(lm[:2], V, F)
    with pytest.raises(LandmarkTooFarError, match="from the surface"):
        resolve_landmarks(lm[:-1] + [[0.0, 0.0, 50.0]], V, F)
    with pytest.raises(LandmarkFormatError):
        resolve_landmarks(lm[:-1] + ["nose"], V, F)
    with pytest.raises(LandmarkCountMismatchError, match="same number"):
        parse_landmark_json({"landmarks": [lm, lm[:-1]]}, 2)
    with pytest.raises(LandmarkCountMismatchError, match="3 meshes"):
        parse_landmark_json({"landmarks": [lm, lm]}, 3)
    with pytest.raises(TooFewLandmarksError):
        parse_landmark_json({"landmarks": [[1, 2], [1, 2]]}, 2)
    with pytest.raises(LandmarkFormatError):
        parse_landmark_json({"something": 1}, 2)
    # every landmark error is a ValueError, which the CLI turns into exit code 2
    assert issubclass(LandmarkTooFarError, ValueError)


def test_shared_data_layouts_are_accepted():
    shared = {"landmarks_multipie68_0based": [1, 2, 3, 4], "outer_boundary_loop_0based": [9]}
    assert parse_landmark_json(shared, 3) == [[1, 2, 3, 4]] * 3
    choi = {
        "face1": {
            "interior_landmarks_0based": [1, 2, 3],
            "boundary_landmarks_0based_per_loop": [[7, 8, 9], [10, 11]],
        },
        "face2": {
            "interior_landmarks_0based": [4, 5, 6],
            "boundary_landmarks_0based_per_loop": [[1, 1, 1], [12, 13]],
        },
    }
    assert parse_landmark_json(choi, 2) == [[1, 2, 3, 10, 11], [4, 5, 6, 12, 13]]


@pytest.mark.shared_data
@pytest.mark.skipif(not SHARED.exists(), reason="../shared/data absent")
def test_shared_landmark_files_read(tmp_path):
    assert len(read_landmark_file(SHARED / "ict_landmarks68.json", 2)[1]) == 68
    assert len(read_landmark_file(SHARED / "meshmonk_landmarks.json", 2)[0]) == 5
    assert len(read_landmark_file(SHARED / "choi_mcq_landmarks.json", 2)[0]) == 15
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(LandmarkFormatError):
        read_landmark_file(bad, 2)
    good = tmp_path / "l.json"
    good.write_text(json.dumps({"landmarks": [[1, 2, 3], [4, 5, 6]]}))
    assert read_landmark_file(good, 2) == [[1, 2, 3], [4, 5, 6]]


def test_inputs_not_mutated():
    V, F, lm = face_mesh()
    V0, F0, lm0 = V.copy(), F.copy(), list(lm)
    resolve_landmarks(lm, V, F)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)
    assert lm == lm0


def test_a_vertex_landmark_sits_at_its_first_use_in_the_triangles():
    """Hand-worked: vertex 2 is first used by triangle 0 at corner 2, vertex 3 by
    triangle 1 at corner 0 (it is also in triangle 2), vertex 5 by no triangle."""
    from conformorph.pipelines.landmarks_io import _first_corner

    F = np.array([[0, 1, 2], [3, 2, 1], [4, 3, 2]])
    tri, corner = _first_corner(F, np.array([2, 3, 4, 5]))
    assert tri.tolist() == [0, 1, 2, -1]
    assert corner.tolist() == [2, 0, 0, 0]


def test_first_corner_agrees_with_the_brute_force_search():
    from conformorph.pipelines.landmarks_io import _first_corner

    rng = np.random.default_rng(3)
    F = rng.integers(0, 400, size=(700, 3))
    vi = rng.choice(450, size=60, replace=False)
    tri, corner = _first_corner(F, vi)
    hit = F[:, None, :] == vi[None, :, None]
    used = hit.any(axis=2).any(axis=0)
    t = np.argmax(hit.any(axis=2), axis=0)
    c = np.argmax(hit[t, np.arange(vi.size)], axis=1)
    assert np.array_equal(tri, np.where(used, t, -1))
    assert np.array_equal(corner[used], c[used])


def test_point_landmarks_get_the_barycentrics_of_their_surface_point():
    V, F, _ = face_mesh()
    rng = np.random.default_rng(0)
    t = rng.choice(F.shape[0], 12, replace=False)
    w = rng.dirichlet(np.ones(3), 12)
    P = np.einsum("mj,mjk->mk", w, V[F[t]])
    got = resolve_landmarks(P.tolist(), V, F)
    assert np.allclose(np.einsum("mj,mjk->mk", got.barycentric, V[F[got.triangle]]), P, atol=1e-12)
    assert np.allclose(got.points, P, atol=1e-12)
    assert np.all(got.snap_distance < 1e-12)


def test_equal_surface_points_name_the_first_pair_in_row_order():
    """Landmarks 2 = 4 and 3 = 5 (1-based): the pair reported is (4, 2), the first
    (i, j), j < i, in row order, as the pairwise scan it replaces reported."""
    V, F, _ = face_mesh()
    P = np.einsum("mj,mjk->mk", np.full((3, 3), 1 / 3), V[F[[5, 40, 90]]])
    pts = [P[0], P[1], P[2], P[1], P[2]]
    with pytest.raises(DuplicateLandmarkError, match=r"landmarks 2 and 4 are the same"):
        resolve_landmarks([p.tolist() for p in pts], V, F)
