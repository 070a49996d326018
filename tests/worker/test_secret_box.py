"""Issue 30, item 11: webhook secrets are not stored in plaintext in the job store
(encrypted with a server key), rows written before are read and then sealed in place."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from sqlalchemy import select

from conformorph.worker import names
from conformorph.worker.config import WorkerSettings
from conformorph.worker.job_store import JobStore
from conformorph.worker.job_store.tables import CallbackRecord
from conformorph.worker.secret_box import (
    KEY_FILE,
    SEALED_PREFIX,
    SecretBox,
    SecretUnreadable,
    box_for,
    seal_plaintext_secrets,
)

SECRET = "correct horse battery staple"


def _stored(store: JobStore, job_id: str) -> str | None:
    with store.session() as s:
        return s.scalar(select(CallbackRecord.secret).where(CallbackRecord.job_id == job_id))


def test_seal_open_and_keys(tmp_path: Path) -> None:
    box = box_for(WorkerSettings(data_dir=tmp_path))
    sealed = box.seal(SECRET)
    assert sealed is not None and sealed.startswith(SEALED_PREFIX) and SECRET not in sealed
    assert box.open(sealed) == SECRET and box.seal(None) is None and box.open(None) is None
    assert box.open(SECRET) == SECRET  # a row written before encryption
    key = tmp_path / KEY_FILE  # made on first use, for this host only
    assert key.is_file() and (os.stat(key).st_mode & 0o777) == 0o600
    assert box_for(WorkerSettings(data_dir=tmp_path)).open(sealed) == SECRET
    # another key (another data directory, or CONFORMORPH_SECRET_KEY) cannot open it
    other = box_for(WorkerSettings(data_dir=tmp_path / "b", secret_key="a passphrase"))
    with pytest.raises(SecretUnreadable, match="CONFORMORPH_SECRET_KEY"):
        other.open(sealed)
    same = SecretBox.for_settings(
        WorkerSettings(data_dir=tmp_path / "c", secret_key="a passphrase")
    )
    assert same.open(other.seal(SECRET)) == SECRET


def test_the_api_stores_the_secret_sealed_and_old_rows_are_migrated(tmp_path: Path) -> None:
    from tests.service.conftest import Api

    api = Api(tmp_path, callback_allow="public,127.0.0.0/8")
    try:
        from conformorph.pipelines.mesh_io import write_obj
        from tests.fixtures.make_service_small_face import small_face

        V, F = small_face(5)
        write_obj(tmp_path / "f.obj", V, F)
        mesh = api.upload(tmp_path / "f.obj").json()["id"]
        body = {"mesh": mesh, "callback_url": "http://127.0.0.1:9/h", "callback_secret": SECRET}
        r = api.client.post("/v1/conformal-maps", json=body)
        assert r.status_code == 202, r.text
        stored = _stored(api.store, r.json()["id"])
        assert stored is not None and stored.startswith(SEALED_PREFIX) and SECRET not in stored
        assert r.json()["callback"]["signed"] is True and SECRET not in r.text
        assert box_for(api.settings).open(stored) == SECRET
        # a row of a store made before: plaintext, read as is, then sealed in place
        old, _ = api.store.create_job(
            owner="open",
            kind=names.KIND_CONFORMAL_MAP,
            params={"callback_url": "http://127.0.0.1:9/h"},
            callback=("http://127.0.0.1:9/h", SECRET),
        )
        assert _stored(api.store, old.id) == SECRET
        assert seal_plaintext_secrets(api.store, box_for(api.settings)) == 1
        migrated = _stored(api.store, old.id)
        assert migrated is not None and migrated.startswith(SEALED_PREFIX)
        assert box_for(api.settings).open(migrated) == SECRET
        assert seal_plaintext_secrets(api.store, box_for(api.settings)) == 0
    finally:
        api.client.close()
        api.store.dispose()
