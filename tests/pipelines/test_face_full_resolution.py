"""Full-resolution output (--output-resolution input): the morph computed on the decimated
working mesh, written at key 0's input resolution."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.geometry.surface_distance import SurfaceDistance
from conformorph.pipelines.mesh_io import read_mesh

from .face_morph_inputs import face_inputs, morph, morph_options, validate_glb
from .glb_playback import MorphGlb


@pytest.fixture(scope="module")
def decimated_morph(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fullres")
    paths, L = face_inputs(tmp, subdivide_first=True)  # key 0: 7,585 vertices, key 1: 1,937
    common = {"frames": 3, "prepare": "auto", "vertex_budget": 2000, "key_metrics": False}
    full = morph(paths, L, tmp / "input", per_frame=True, **common)
    working = morph(paths, L, tmp / "working", output_resolution="working", **common)
    return paths, tmp, full, working


def test_key0_decimated_and_written_back_at_input_resolution(decimated_morph):
    paths, tmp, full, working = decimated_morph
    V0, F0 = read_mesh(paths[0])
    rep = full["output_resolution"]
    assert rep["output_resolution"] == "input" and rep["vertices"] == V0.shape[0]
    assert rep["working_vertices"] < 2100
    assert working["output_resolution"] == {"output_resolution": "working"}
    m = MorphGlb.load(tmp / "input" / "animation.glb")
    w = MorphGlb.load(tmp / "working" / "animation.glb")
    assert m.base_V.shape[0] == V0.shape[0] and w.base_V.shape[0] == rep["working_vertices"]
    metres = full["units"]["metres_per_working_unit"]
    diag = float(np.linalg.norm(np.ptp(V0, axis=0)))
    # frame 0 (key 0) is the input itself, vertex for vertex
    np.testing.assert_allclose(m.positions(0.0), V0 * metres, atol=1e-6 * diag * metres)
    # the last frame lies on key 1's surface as closely as the working mesh's frame does
    V1, F1 = read_mesh(paths[1])
    surf = SurfaceDistance(V1 * metres, F1)
    d_full = surf.closest_points(m.positions(1.0))[1]
    d_work = surf.closest_points(w.positions(1.0))[1]
    assert np.mean(d_full) <= 2 * np.mean(d_work) + 1e-4 * diag * metres
    validate_glb([tmp / "input" / "animation.glb", tmp / "input" / "frames" / "002.glb"])


def test_auto_keeps_the_working_mesh_above_its_cap_and_says_why():
    from conformorph.pipelines.face_morph.full_resolution import (
        AUTO_MAX_VERTICES,
        DEFAULT_OUTPUT_RESOLUTION,
        full_resolution_frames,
    )
    from tests.meshes import bumpy_disk

    assert (DEFAULT_OUTPUT_RESOLUTION, AUTO_MAX_VERTICES) == ("auto", 300_000)
    V, F = bumpy_disk(6)
    Vd, Fd = bumpy_disk(12)  # the "input": denser than the working mesh
    reg = {"cm_F": F}
    frames = {
        "frames_V": np.stack([V, 1.1 * V]),
        "frame_R": np.stack([np.eye(3)] * 2),
        "frame_t": np.zeros((2, 3)),
        "frame_s": np.ones(2),
        "frame_times": np.array([0.0, 1.0]),
    }
    _, fr, rep = full_resolution_frames(reg, frames, 0.0, (Vd, Fd), max_vertices=10)
    assert rep["output_resolution"] == "working" and "--output-resolution input" in rep["reason"]
    assert fr is frames
    reg2, fr2, rep2 = full_resolution_frames(reg, frames, 0.0, (Vd, Fd))
    assert rep2["output_resolution"] == "input" and fr2["frames_V"].shape == (2, Vd.shape[0], 3)
    np.testing.assert_array_equal(reg2["cm_F"], Fd)
    np.testing.assert_allclose(fr2["frames_V"][1], 1.1 * fr2["frames_V"][0], atol=1e-9)


def test_auto_above_its_cap_is_decided_from_the_report_without_reading_key_0(tmp_path, monkeypatch):
    """``auto`` with key 0 above the cap keeps the working mesh and says why, from the
    preparation report's vertex count: key 0 is not parsed again for nothing."""
    import conformorph.pipelines.face_morph.full_resolution as full_resolution
    import conformorph.pipelines.mesh_io as mesh_io

    paths, L = face_inputs(tmp_path, subdivide_first=True)  # key 0: 7,585 vertices
    monkeypatch.setattr(full_resolution, "AUTO_MAX_VERTICES", 5000)
    reads: list[str] = []
    real_read = mesh_io.read_mesh

    def counted(path, *a, **k):
        reads.append(str(path))
        return real_read(path, *a, **k)

    monkeypatch.setattr(mesh_io, "read_mesh", counted)
    common = {"frames": 2, "prepare": "auto", "vertex_budget": 2000, "key_metrics": False}
    got = morph(paths, L, tmp_path / "auto", **common)
    rep = got["output_resolution"]
    assert rep["output_resolution"] == "working"
    assert "7,585 vertices" in rep["reason"] and "--output-resolution input" in rep["reason"]
    assert reads.count(str(paths[0])) == 1  # by the preparation only


def test_key_0_is_read_ahead_in_the_key_pool_when_the_export_may_write_it(tmp_path, monkeypatch):
    import conformorph.pipelines.face_morph.run as run

    paths, L = face_inputs(tmp_path, subdivide_first=True)

    def options(choice, **kw):
        return morph_options(output_resolution=choice, **kw)

    assert not run._key0_read_ahead(paths[0], options("working"))
    assert not run._key0_read_ahead(paths[0], options("input", write_glb=False))
    assert run._key0_read_ahead(paths[0], options("input"))
    assert run._key0_read_ahead(paths[0], options("auto"))  # a small file
    monkeypatch.setattr(run, "AUTO_READ_AHEAD_MAX_BYTES", 10)
    assert not run._key0_read_ahead(paths[0], options("auto"))
    # threads (small files): no read ahead; processes: one more job of the key pool
    opts = options("input", prepare="auto", vertex_budget=2000, key_processes=True)
    keys, dense = run._prepare_keys_reading_ahead(paths, L, None, opts, True)
    assert dense is None and len(keys) == 2
    monkeypatch.setattr(run, "PROCESS_KEYS_MIN_BYTES", 0)
    keys2, dense2 = run._prepare_keys_reading_ahead(paths, L, None, opts, True)
    V, F = dense2.result(timeout=120)
    V0, F0 = read_mesh(paths[0])
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)
    np.testing.assert_array_equal(keys2[0]["V"], keys[0]["V"])  # the same keys either way
