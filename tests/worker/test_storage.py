"""Local artifact storage: safe keys, atomic writes, ETags, deletion."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from conformorph.worker.storage import (
    ArtifactNotFound,
    LocalStorage,
    Storage,
    StorageKeyError,
    check_key,
)


def test_put_get_and_etag(tmp_path: Path) -> None:
    st = LocalStorage(tmp_path)
    assert isinstance(st, Storage)
    obj = st.put_bytes("jobs/j1/map-abc/disk_map.npz", b"hello")
    assert obj.size == 5 and obj.sha256 == hashlib.sha256(b"hello").hexdigest()
    assert st.read_bytes(obj.key) == b"hello" and st.size(obj.key) == 5
    st.put_bytes(obj.key, b"hello again")  # overwrite is atomic: no temp files remain
    assert st.read_bytes(obj.key) == b"hello again"
    assert [p.name for p in (tmp_path / "jobs/j1/map-abc").iterdir()] == ["disk_map.npz"]
    assert list(st.iter_keys("jobs/j1")) == ["jobs/j1/map-abc/disk_map.npz"]
    with pytest.raises(ArtifactNotFound):
        st.open("jobs/j1/none.bin")
    with pytest.raises(ArtifactNotFound):
        st.local_path("jobs/j1/none.bin")


def test_put_file_moves_or_copies(tmp_path: Path) -> None:
    st = LocalStorage(tmp_path / "root")
    src = tmp_path / "a.obj"
    src.write_bytes(b"v 0 0 0\n")
    st.put_file("meshes/o/a.obj", src)
    assert src.exists()
    obj = st.put_file("meshes/o/b.obj", src, move=True)
    assert not src.exists() and st.read_bytes("meshes/o/b.obj") == b"v 0 0 0\n"
    assert obj.sha256 == hashlib.sha256(b"v 0 0 0\n").hexdigest()


@pytest.mark.parametrize(
    "key", ["", "/etc/passwd", "../x", "a/../b", "a//b", "a/.hidden", "a b", "a\\b"]
)
def test_bad_keys_are_refused(tmp_path: Path, key: str) -> None:
    with pytest.raises(StorageKeyError):
        check_key(key)
    with pytest.raises(StorageKeyError):
        LocalStorage(tmp_path).put_bytes(key, b"x")


def test_delete_prefix_and_ping(tmp_path: Path) -> None:
    st = LocalStorage(tmp_path)
    st.put_bytes("jobs/j1/a/x.json", b"{}")
    st.put_bytes("jobs/j2/a/x.json", b"{}")
    st.delete_prefix("jobs/j1")
    assert not st.exists("jobs/j1/a/x.json") and st.exists("jobs/j2/a/x.json")
    st.delete("jobs/j2/a/x.json")
    st.delete("jobs/j2/a/x.json")  # deleting twice is fine
    assert st.ping()
