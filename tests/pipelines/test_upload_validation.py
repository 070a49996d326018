"""The conformal-map and reconstruction stages' repairs, below the API."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from conformorph.geometry.mesh_errors import MultipleComponentsError, NotDiskError
from conformorph.pipelines.upload_validation import repairable_mesh
from conformorph.worker.stages.surface import REPAIRED_MAP, _stored
from tests.fixtures.make_service_small_face import small_face, with_hole_and_ear


def test_repairable_mesh_names_the_repairs_a_disk_needs() -> None:
    V, F = small_face(6)
    V2, F2, ear = with_hole_and_ear(V, F)
    _, repairs = repairable_mesh(V2, F2, NotDiskError("strict validation failed"))
    assert repairs == {"fill_holes": 1, "remove_ears": [ear]}


def test_repairable_mesh_re_raises_what_no_repair_fixes() -> None:
    V, F = small_face(6)
    two = np.vstack([V, V + [10.0, 0, 0]]), np.vstack([F, F + V.shape[0]])
    err = NotDiskError("two pieces")
    with pytest.raises(NotDiskError) as info:
        repairable_mesh(*two, err)
    assert info.value is err  # the strict error, not the lenient check's
    with pytest.raises(MultipleComponentsError):  # not a repairable kind of error at all
        repairable_mesh(V, F, MultipleComponentsError("x"))


def test_a_job_begun_before_repaired_artifacts_existed_reads_the_public_one() -> None:
    old = SimpleNamespace(job=SimpleNamespace(artifacts={"disk_map.npz": {}}), artifacts={})
    assert _stored(old, REPAIRED_MAP, "disk_map.npz") == "disk_map.npz"  # type: ignore[arg-type]
    new = SimpleNamespace(job=SimpleNamespace(artifacts={REPAIRED_MAP: {}}), artifacts={})
    assert _stored(new, REPAIRED_MAP, "disk_map.npz") == REPAIRED_MAP  # type: ignore[arg-type]
    same = SimpleNamespace(job=SimpleNamespace(artifacts={}), artifacts={REPAIRED_MAP: {}})
    assert _stored(same, REPAIRED_MAP, "disk_map.npz") == REPAIRED_MAP  # type: ignore[arg-type]


def test_the_report_counts_interior_and_boundary_vertices_and_holds_no_arrays():
    from conformorph.pipelines.mesh_io import MeshLimits
    from conformorph.pipelines.upload_validation import validate_mesh_upload
    from tests.fixtures.malformed_corpus import valid_disk_files

    # a hexagon fan (centre + 6) inside a ring of 6: 7 interior vertices, 6 on the boundary
    out = validate_mesh_upload(valid_disk_files()["obj"], "obj", MeshLimits(1000, 1000))
    report = out["report"]
    assert (report["interior_vertices"], report["boundary_vertices"]) == (7, 6)
    assert report["n_vertices"] == 13 and report["boundary_loop_sizes"] == [6]
    assert "boundary" not in report and "edges" not in report
    # a single triangle: no interior vertex
    tri = validate_mesh_upload(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "obj", MeshLimits())
    assert tri["report"]["interior_vertices"] == 0


def test_unexpected_failures_are_logged_not_shown(monkeypatch):
    import conformorph.pipelines.upload_validation as uv
    from conformorph.pipelines.mesh_io import MeshLimits

    def bug(*_args, **_kwargs):
        raise TypeError("'NoneType' object is not subscriptable")

    monkeypatch.setattr(uv, "read_mesh", bug)
    err = uv.validate_mesh_upload(b"v 0 0 0\n", "obj", MeshLimits())["error"]
    assert err["type"] == "unreadable_mesh" and "NoneType" not in err["message"]
    monkeypatch.setattr(uv, "parse_shape_parts", bug)
    err = uv.validate_shape_upload(b"{}", ".json")["error"]
    assert err["type"] == "unreadable_shape" and "NoneType" not in err["message"]


def test_shape_messages_call_the_file_the_uploaded_shape():
    from conformorph.pipelines.upload_validation import validate_shape_upload

    err = validate_shape_upload(b'{"rings": [[[0, 0], [1, 0]]', ".json")["error"]
    assert err["message"].startswith("the uploaded shape: not valid JSON")
