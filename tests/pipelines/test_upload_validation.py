"""The conformal-map and reconstruction stages' repairs, below the API."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from geometry.mesh_errors import MultipleComponentsError, NotDiskError
from pipelines.upload_validation import repairable_mesh
from tests.fixtures.make_service_small_face import small_face, with_hole_and_ear
from worker.stages.surface import REPAIRED_MAP, _stored


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
