import numpy as np

from conformorph import geometry as g
from tests.meshes import bumpy_disk, disk_grid


def test_corner_angles_by_hand():
    V = np.array([[0, 0], [1, 0], [0, 1]], dtype=float)
    np.testing.assert_allclose(
        np.degrees(g.corner_angles(V, np.array([[0, 1, 2]]))), [[90, 45, 45]], atol=1e-13
    )
    # near-degenerate: atan2 keeps tiny angles accurate
    V = np.array([[0, 0], [1, 0], [1, 1e-9]])
    assert abs(g.corner_angles(V, np.array([[0, 1, 2]]))[0, 0] - 1e-9) < 1e-18


def test_angle_sums_and_distortion_of_similarities():
    V, F = bumpy_disk(6)
    np.testing.assert_allclose(g.corner_angles(V, F).sum(axis=1), np.pi, atol=1e-12)
    Vf, F = disk_grid(4)
    c, s = np.cos(0.7), np.sin(0.7)
    uv = 2.0 * Vf[:, :2] @ np.array([[c, -s], [s, c]]).T + 1.0
    np.testing.assert_allclose(g.angle_distortion(Vf, F, uv), 0, atol=1e-12)


def test_distortion_and_flip_of_a_sheared_triangle_by_hand():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    F = np.array([[0, 1, 2]])
    uv = np.array([[0, 0], [1, 0], [1, 1]], dtype=float)  # angles 45, 90, 45
    np.testing.assert_allclose(g.angle_distortion(V, F, uv), [[45, 45, 0]], atol=1e-12)
    assert not g.flipped_triangles(uv, F)[0]
    assert g.flipped_triangles(uv[:, ::-1], F)[0]
    np.testing.assert_allclose(g.signed_areas_2d(uv, F), [0.5])
