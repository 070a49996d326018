"""The Embree scene of landmark detection's ray caster (embreex used directly, not through
trimesh): hits worked by hand at every scale, and the same float32 hits as trimesh's
``RayMeshIntersector`` scene that it replaces. Skipped where embreex is not installed."""

import numpy as np
import pytest

from tests.meshes import disk_grid, random_rotation, spherical_cap

embreex = pytest.importorskip(
    "embreex", reason="embreex not installed (scripts/install_landmarks.sh)"
)


def _scene(V: np.ndarray, F: np.ndarray):  # type: ignore[no-untyped-def]
    from conformorph.pipelines.landmark_detection.render import _EmbreeScene

    return _EmbreeScene(np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64))


@pytest.mark.parametrize("size", [1e-3, 1.0, 1e3])
def test_one_triangle_hit_and_missed_by_hand_at_every_scale(size: float) -> None:
    # the triangle (0,0,0), (1,0,0), (0,1,0) scaled by `size`; rays straight down
    V = size * np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    F = np.array([[0, 1, 2]])
    xy = size * np.array([[0.25, 0.25], [0.1, 0.7], [0.6, 0.6], [-0.1, 0.2]])
    origins = np.column_stack([xy, np.full(4, size)])
    directions = np.tile([0.0, 0.0, -1.0], (4, 1))
    q = _scene(V, F).run(origins, directions)
    assert q["geomID"].tolist() == [0, 0, -1, -1]
    assert q["primID"][:2].tolist() == [0, 0]
    # u, v: the weights of corners 1 and 2, that is x and y over the size
    np.testing.assert_allclose(q["u"][:2], [0.25, 0.1], atol=1e-6)
    np.testing.assert_allclose(q["v"][:2], [0.25, 0.7], atol=1e-6)


def test_the_same_hits_as_trimesh_scene_it_replaces() -> None:
    trimesh = pytest.importorskip("trimesh")
    from trimesh.ray.ray_pyembree import RayMeshIntersector

    rng = np.random.default_rng(3)
    for seed, (V, F) in enumerate((disk_grid(12), spherical_cap(14, 0.9))):
        V = 37.0 * V @ random_rotation(seed).T + np.array([5.0, -2.0, 11.0])
        # an unreferenced vertex far away: the scale is taken from the mesh's triangles
        V = np.vstack([V, [1e4, 1e4, 1e4]])
        lo, hi = V[:-1].min(axis=0), V[:-1].max(axis=0)
        origins = lo + rng.random((4000, 3)) * (hi - lo)
        directions = rng.normal(size=(4000, 3))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        ours = _scene(V, F).run(origins, directions)
        mesh = trimesh.Trimesh(V, F, process=False, validate=False)
        theirs = RayMeshIntersector(mesh)._scene.run(origins, directions, output=1)
        assert (ours["geomID"] >= 0).sum() > 100
        for key in ("geomID", "primID", "u", "v", "tfar"):
            np.testing.assert_array_equal(ours[key], theirs[key], err_msg=key)
