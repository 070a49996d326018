"""Full-resolution output (--output-resolution input): the morph computed on the decimated
working mesh, written at key 0's input resolution."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.geometry.surface_distance import SurfaceDistance
from conformorph.pipelines.mesh_io import read_mesh

from .face_morph_inputs import face_inputs, morph, validate_glb
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
