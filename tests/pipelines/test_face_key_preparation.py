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
