import pytest

from conformorph.pipelines.face_morph import (
    prepare_mesh,
)

from .face_morph_inputs import (
    folded_face,
)


def test_prepare_mesh_refuses_a_disk_map_the_repair_leaves_folded(monkeypatch):
    import functools

    from conformorph import geometry
    from conformorph.geometry.mesh_errors import FoldedMapError

    V, F, lm = folded_face()
    ok = prepare_mesh(V, F, lm, mesh_index=1)  # the repair unfolds it: accepted, reported
    assert ok["meta"]["disk_map"]["flipped"] == 0
    assert ok["meta"]["disk_map"]["flipped_before_repair"] > 0
    # the same real map without its repair stands for a fold the repair could not undo
    no_repair = functools.partial(geometry.disk_conformal_map, fold_policy="report")
    monkeypatch.setattr(geometry, "disk_conformal_map", no_repair)
    with pytest.raises(FoldedMapError, match="mesh 1: the disk map still has 2 folded"):
        prepare_mesh(V, F, lm, mesh_index=1)


def test_api_offers_the_pipelines_curvature_homotopies_and_default():
    import typing

    from conformorph.pipelines.face_morph import CURVATURE_HOMOTOPIES, DEFAULT_CURVATURE
    from conformorph.service.schemas import MorphCreate

    field = MorphCreate.model_fields["curvature"]
    assert field.default == DEFAULT_CURVATURE
    assert set(typing.get_args(field.annotation)) == set(CURVATURE_HOMOTOPIES)


def test_landmark_vertex_ids_and_closed_key_cut_around_them():
    import numpy as np

    from conformorph.geometry import validate_mesh
    from conformorph.pipelines.face_morph.key_preparation import (
        landmark_vertex_ids,
        prepare_key_arrays,
    )
    from tests.meshes import closed_head

    V, F = closed_head()
    # ids kept, a point snapped to its nearest vertex, junk and out-of-range skipped
    ids = landmark_vertex_ids([3, [0.0, 0.0, 2.0], True, 10_000, "x", [1.0, 2.0]], V)
    assert ids is None  # only two usable entries: the cut then reads the shape
    tip = int(np.argmax(V[:, 2]))
    near = [int(i) for i in np.argsort(np.linalg.norm(V - V[tip], axis=1))[:30:6]]
    entries = [*near[:-1], V[near[-1]].tolist()]
    assert landmark_vertex_ids(entries, V).tolist() == near
    V2, F2, new, uv, col, prepared = prepare_key_arrays(V, F, entries, None, None, 0)
    assert prepared.report["face_cut"]["from_landmarks"] and uv is None and col is None
    validate_mesh(V2, F2, require_disk=True)
    np.testing.assert_array_equal(V2[new[:-1]], V[near[:-1]])
    assert new[-1] == entries[-1]  # points stay points
