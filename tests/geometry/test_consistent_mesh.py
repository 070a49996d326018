import numpy as np
import pytest

from conformorph.geometry.consistent_mesh import (
    consistent_mesh,
    landmark_disk_mesh,
    refine_disk_mesh,
    refinement_levels,
    resample_vertex_data,
)
from conformorph.geometry.flipped_triangles import signed_areas_2d

P = np.array([[0.1, 0.2], [-0.3, 0.1], [0.2, -0.4], [0.0, 0.5]])


def test_hand_worked_coarse_mesh():
    uv, F = landmark_disk_mesh(P, n_boundary=4)
    assert uv.shape == (8, 2)
    np.testing.assert_array_equal(uv[:4], P)  # landmarks are nodes, in order
    # disk triangulation of 8 points, 4 on the hull: F = 2n - h - 2 = 10
    assert F.shape == (10, 3)
    assert (signed_areas_2d(uv, F) > 0).all()


def test_refinement_counts_and_circle():
    uv, F = landmark_disk_mesh(P, n_boundary=8)
    for k in range(4):
        u2, F2 = refine_disk_mesh(uv, F, k)
        assert F2.shape[0] == 4**k * F.shape[0]
        assert refinement_levels(uv.shape[0], F.shape[0], u2.shape[0]) == k
        assert (signed_areas_2d(u2, F2) > 0).all()
        r = np.linalg.norm(u2, axis=1)
        assert r.max() <= 1 + 1e-12
        # Euler characteristic of a disk
        E = {tuple(sorted(e)) for f in F2 for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
        assert u2.shape[0] - len(E) + F2.shape[0] == 1
    cm = consistent_mesh(uv, F, P, levels=2)
    np.testing.assert_allclose(np.linalg.norm(cm.uv[cm.b], axis=1), 1.0, atol=1e-12)
    assert cm.b.size == 32 * 4  # default n_boundary = 32, doubled twice


def test_resampling_reproduces_linear_data_and_source_mode():
    src_uv, src_F = refine_disk_mesh(*landmark_disk_mesh(P, n_boundary=10), 3)
    cm = consistent_mesh(src_uv, src_F, P, target_vertices=500)
    assert cm.uv.shape[0] >= 500
    vals = np.c_[2 * src_uv[:, 0] - src_uv[:, 1], src_uv[:, 1] + 3]
    out = resample_vertex_data(src_uv, src_F, vals, cm.uv)
    ref = np.c_[2 * cm.uv[:, 0] - cm.uv[:, 1], cm.uv[:, 1] + 3]
    inside = np.linalg.norm(cm.uv, axis=1) < 0.95
    np.testing.assert_allclose(out[inside], ref[inside], atol=1e-12)
    cs = consistent_mesh(src_uv, src_F, P, mode="source")
    np.testing.assert_array_equal(cs.F, src_F)
    with pytest.raises(ValueError):
        consistent_mesh(src_uv, src_F, P, mode="other")


def test_errors_and_no_mutation():
    P0 = P.copy()
    landmark_disk_mesh(P)
    np.testing.assert_array_equal(P, P0)
    with pytest.raises(ValueError, match="coincide"):
        landmark_disk_mesh(np.vstack([P, P[:1]]))
    with pytest.raises(ValueError, match="inside"):
        landmark_disk_mesh(np.array([[1.0, 0.0]]))


def _square():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return uv, np.array([[0, 1, 2], [0, 2, 3]])


def _gradient(h, w):
    """An image linear in (u, v): bilinear sampling reproduces it exactly inside."""
    r, c = np.mgrid[0:h, 0:w]
    u, v = (c + 0.5) / w, 1.0 - (r + 0.5) / h
    return np.stack([u, v, 0.3 * u + 0.5 * v], axis=2)


def test_sample_image_hand_worked():
    from conformorph.geometry.consistent_mesh import sample_image

    img = np.array([[[0.0], [1.0]], [[2.0], [3.0]]])  # top row 0, 1; bottom row 2, 3
    uv = np.array([[0.25, 0.75], [0.75, 0.75], [0.25, 0.25], [0.5, 0.5], [-1.0, 2.0]])
    np.testing.assert_allclose(sample_image(img, uv)[:, 0], [0, 1, 2, 1.5, 0])
    with pytest.raises(ValueError, match="image"):
        sample_image(np.zeros((2, 2)), uv)


def test_resample_texture_identity_mirror_and_padding():
    from conformorph.geometry.consistent_mesh import resample_texture

    uv, F = _square()
    img = _gradient(8, 12)
    same, covered = resample_texture(uv, F, uv, img, (8, 12))
    assert covered.all()
    np.testing.assert_allclose(same, img, atol=1e-12)
    # the source image mirrored left-right and its coordinates with it: the same picture
    mirrored = img[:, ::-1]
    back, _ = resample_texture(uv, F, np.c_[1.0 - uv[:, 0], uv[:, 1]], mirrored, (8, 12))
    np.testing.assert_allclose(back, img, atol=1e-12)
    # a layout on the left half only: right-half texels are padded from the nearest
    # covered texel (column 5 of a 12-wide texture)
    half = np.c_[0.5 * uv[:, 0], uv[:, 1]]
    tex, covered = resample_texture(half, F, uv, img, (8, 12))
    assert covered[:, :6].all() and not covered[:, 6:].any()
    np.testing.assert_allclose(tex[:, 7:], np.repeat(tex[:, 5:6], 5, axis=1))
    # the left half now shows the whole source, squeezed: texel (r, c) ↦ u = 2 (c + 0.5) / 12
    r, c = 3, 2
    np.testing.assert_allclose(tex[r, c, 0], 2 * (c + 0.5) / 12, atol=1e-12)


def test_resample_texture_bad_input_and_no_mutation():
    from conformorph.geometry.consistent_mesh import resample_texture

    uv, F = _square()
    img = _gradient(4, 4)
    keep = uv.copy(), F.copy(), img.copy()
    resample_texture(uv, F, uv, img, (4, 4))
    for a, b in zip((uv, F, img), keep, strict=True):
        assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="both be"):
        resample_texture(uv, F, uv[:3], img, (4, 4))
    with pytest.raises(ValueError, match="indexes"):
        resample_texture(uv, F + 2, uv, img, (4, 4))
    with pytest.raises(ValueError, match="covers no texel"):
        resample_texture(uv * 0.01 + 2.0, F, uv, img, (4, 4))
    with pytest.raises(ValueError, match="positive"):
        resample_texture(uv, F, uv, img, (0, 4))


def test_resample_texture_in_chunks_equals_at_once(monkeypatch):
    import importlib

    cm = importlib.import_module("conformorph.geometry.consistent_mesh")

    uv, F = landmark_disk_mesh(P, n_boundary=12)
    uv, F = refine_disk_mesh(uv, F, 2)
    layout = 0.5 + 0.45 * uv
    src = 0.5 + 0.4 * uv[:, ::-1]
    img = _gradient(16, 16)
    whole, cov = cm.resample_texture(layout, F, src, img, (20, 24))
    monkeypatch.setattr(cm, "_RASTER_CHUNK", 7)
    parts, cov2 = cm.resample_texture(layout, F, src, img, (20, 24))
    np.testing.assert_array_equal(cov, cov2)
    np.testing.assert_allclose(parts, whole, atol=1e-12)
