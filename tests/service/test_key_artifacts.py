"""Uploaded meshes' key artifacts: precomputed after the upload (the task sent by name),
found by the morph's prepare stage, counted in the quota, deleted with their mesh."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.mesh_io import write_obj
from conformorph.worker.key_artifacts import key_artifact_prefix, precompute_key_artifact
from conformorph.worker.retention import run_cleanup
from conformorph.worker.stages.face_morph import default_key_options
from tests.fixtures.make_service_small_face import small_face
from tests.service.conftest import Api

DAY = 86400.0


@pytest.fixture
def face_pair(tmp_path: Path) -> tuple[Path, Path, list[int]]:
    V, F = small_face(10)
    W = V.copy()
    W[:, 2] += 3.0 * np.sin(V[:, 0] / 30.0)
    a, b = tmp_path / "face_a.obj", tmp_path / "face_b.obj"
    write_obj(a, V, F)
    write_obj(b, W, F)
    r = np.linalg.norm(V[:, :2] / np.array([80.0, 100.0]), axis=1)
    ring = np.flatnonzero(np.abs(r - 0.5) < 0.02)
    return a, b, [0, *[int(i) for i in ring[:: max(1, ring.size // 8)][:8]]]


def _upload(api: Api, path: Path) -> str:
    r = api.client.post("/v1/meshes", files={"file": (path.name, path.read_bytes())})
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def _key_files(api: Api, mesh_id: str) -> list[str]:
    return list(api.storage.iter_keys(key_artifact_prefix("open", mesh_id)))  # type: ignore[attr-defined]


def _morph(api: Api, ids: list[str], lm: list[int], frames: int = 3) -> dict[str, object]:
    r = api.client.post("/v1/morphs", json={"meshes": ids, "landmarks": [lm, lm], "frames": frames})
    assert r.status_code == 202, r.text
    outs = api.run_job(r.json()["id"])
    assert [o.status for o in outs] == ["ran"] * 5, outs[-1].job
    got = api.client.get(f"/v1/jobs/{r.json()['id']}/artifacts/metrics.json").json()
    assert isinstance(got, dict)
    return got


def test_upload_precomputes_and_the_morph_finds_it(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    a, b, lm = face_pair
    ids = [_upload(api, a), _upload(api, b)]
    assert api.tasks.precomputed == [("open", ids[0]), ("open", ids[1])]
    # a repeat upload of the same bytes sends nothing more
    assert (
        api.client.post("/v1/meshes", files={"file": (a.name, a.read_bytes())}).status_code == 200
    )
    assert len(api.tasks.precomputed) == 2
    done = precompute_key_artifact(api.storage, api.store, "open", ids[0], default_key_options())
    assert done["state"] == "stored" and len(_key_files(api, ids[0])) == 1
    assert precompute_key_artifact(api.storage, api.store, "open", ids[0], default_key_options())["state"] == "hit"
    assert precompute_key_artifact(api.storage, api.store, "open", "0" * 32, default_key_options())["state"] == "gone"

    first = _morph(api, ids, lm)
    states = [m["cache"]["state"] for m in first["inputs"]]  # type: ignore[index]
    assert states == ["hit", "stored"]  # mesh 1 was not precomputed: the job stored it
    again = _morph(api, ids, lm, frames=4)  # the same meshes again: both ready
    assert [m["cache"]["state"] for m in again["inputs"]] == ["hit", "hit"]  # type: ignore[index]
    assert again["frames"]["key_frame_L2_to_inputs"] == first["frames"]["key_frame_L2_to_inputs"]  # type: ignore[index]


def test_quota_counts_key_artifacts_and_cleanup_deletes_them(
    api: Api, face_pair: tuple[Path, Path, list[int]]
) -> None:
    a, _, _ = face_pair
    mesh = _upload(api, a)
    size = a.stat().st_size
    assert api.store.storage_used("open") == size
    precompute_key_artifact(api.storage, api.store, "open", mesh, default_key_options())
    (key,) = _key_files(api, mesh)
    art = api.storage.size(key)
    assert art > 0 and api.store.storage_used("open") == size + art
    assert api.store.storage_used("someone-else") == 0
    report = run_cleanup(
        api.store,
        api.storage,
        job_retention_seconds=7 * DAY,
        upload_retention_seconds=7 * DAY,
        now=time.time() + 8 * DAY,
    )
    assert (report.uploads, report.bytes) == (1, size + art)
    assert _key_files(api, mesh) == [] and api.store.storage_used("open") == 0
    assert api.store.key_artifacts_of("open", mesh) == []


@pytest.mark.parametrize("report", [{}, {"preparation_needed": {"holes": 1}}])
def test_precompute_uses_the_options_of_a_default_job(report: dict[str, object]) -> None:
    from conformorph.service.schemas import MorphCreate
    from conformorph.worker.stages.face_morph import morph_options_from_params

    # the fields a default POST /v1/morphs body stores in the job's params
    body = MorphCreate(meshes=["a" * 32, "b" * 32], landmarks=[[0, 1, 2], [0, 1, 2]])
    params = body.model_dump(
        include={"prepare", "vertex_budget", "disk_method"}, exclude_unset=False
    )
    assert default_key_options() == morph_options_from_params(params).keys
