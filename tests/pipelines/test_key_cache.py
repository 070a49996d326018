"""The key cache: a key's per-mesh work found again for the same bytes and options only,
equal to a fresh computation, unreadable entries replaced, concurrent writers harmless."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conformorph.pipelines.face_morph.key_artifact import (
    CorruptArtifactError,
    artifact_bytes,
    artifact_from_bytes,
    key_artifact_key,
)
from conformorph.pipelines.face_morph.key_cache import (
    DirectoryArtifactStore,
    cached_artifact,
    default_cache_dir,
    prepare_key_cached,
)
from conformorph.pipelines.face_morph.key_preparation import prepare_key_file
from conformorph.pipelines.face_morph.options import KeyOptions
from conformorph.pipelines.mesh_io import read_mesh
from tests.fixtures.make_service_small_face import small_face

SURFACE = ("V", "F", "Vn", "uv", "lam", "H", "Hn", "lm_tri", "lm_bary", "lm_uv", "lm_points")
AUTO = KeyOptions(prepare="auto")


def _write_obj(path: Path, V: np.ndarray, F: np.ndarray) -> Path:
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in V] + [
        f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def face(tmp_path: Path) -> tuple[Path, list[Any]]:
    V, F = small_face(rings=25)  # 1,951 vertices
    return _write_obj(tmp_path / "face.obj", V, F), [0, 40, 300, 900, 1400, 1900]


def _fresh(path: Path, entries: list[Any], options: KeyOptions) -> dict[str, Any]:
    V, F = read_mesh(path)
    out: dict[str, Any] = prepare_key_file(V, F, entries, 0, path, options=options)
    return out


def _assert_same(a: dict[str, Any], b: dict[str, Any]) -> None:
    for k in SURFACE:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_hit_equals_a_fresh_computation(face: tuple[Path, list[Any]], tmp_path: Path) -> None:
    path, entries = face
    store = DirectoryArtifactStore(tmp_path / "cache")
    first = prepare_key_cached(store, path, entries, 0, options=AUTO)
    second = prepare_key_cached(store, path, entries, 0, options=AUTO)
    assert first["meta"]["cache"]["state"] == "stored"
    assert second["meta"]["cache"]["state"] == "hit"
    fresh = _fresh(path, entries, AUTO)
    _assert_same(first, fresh)
    _assert_same(second, fresh)
    # other landmarks on the same mesh: still a hit (the landmarks are per pair)
    third = prepare_key_cached(store, path, [1, 2, 3, 700, 1250, 1810], 0, options=AUTO)
    assert third["meta"]["cache"]["state"] == "hit"
    _assert_same(third, _fresh(path, [1, 2, 3, 700, 1250, 1810], AUTO))


def test_never_served_for_other_bytes(face: tuple[Path, list[Any]], tmp_path: Path) -> None:
    path, entries = face
    store = DirectoryArtifactStore(tmp_path / "cache")
    prepare_key_cached(store, path, entries, 0, options=AUTO)
    V, F = read_mesh(path)
    V[5, 2] += 0.25  # one coordinate of one vertex
    other = _write_obj(tmp_path / "face.obj", V, F)  # the same path, other bytes
    got = prepare_key_cached(store, other, entries, 0, options=AUTO)
    assert got["meta"]["cache"]["state"] == "stored"
    _assert_same(got, _fresh(other, entries, AUTO))
    assert got["V"][5, 2] == V[5, 2]


@pytest.mark.parametrize(
    "other",
    [
        KeyOptions(prepare="none"),
        KeyOptions(prepare="auto", vertex_budget=1000),
        KeyOptions(prepare="auto", disk_method="qiem"),
    ],
)
def test_never_served_for_other_options(
    face: tuple[Path, list[Any]], tmp_path: Path, other: KeyOptions
) -> None:
    path, entries = face
    store = DirectoryArtifactStore(tmp_path / "cache")
    prepare_key_cached(store, path, entries, 0, options=AUTO)
    got = prepare_key_cached(store, path, entries, 0, options=other)
    assert got["meta"]["cache"]["state"] == "stored"
    _assert_same(got, _fresh(path, entries, other))


def test_decimated_key_carries_its_landmarks_like_the_fresh_path(
    face: tuple[Path, list[Any]], tmp_path: Path
) -> None:
    path, entries = face
    options = KeyOptions(prepare="auto", vertex_budget=1000)
    store = DirectoryArtifactStore(tmp_path / "cache")
    prepare_key_cached(store, path, entries, 0, options=options)
    hit = prepare_key_cached(store, path, entries, 0, options=options)
    fresh = _fresh(path, entries, options)
    assert hit["meta"]["cache"]["state"] == "hit" and hit["V"].shape[0] < 1951
    _assert_same(hit, fresh)
    np.testing.assert_array_equal(hit["prep_vertex_map"], fresh["prep_vertex_map"])
    assert hit["meta"]["preparation"] == fresh["meta"]["preparation"]


@pytest.mark.parametrize("damage", ["truncate", "flip", "empty"])
def test_a_damaged_entry_is_detected_and_recomputed(
    face: tuple[Path, list[Any]], tmp_path: Path, damage: str
) -> None:
    path, entries = face
    store = DirectoryArtifactStore(tmp_path / "cache")
    key = prepare_key_cached(store, path, entries, 0, options=AUTO)["meta"]["cache"]["key"]
    f = store.path(key)
    data = bytearray(f.read_bytes())
    if damage == "truncate":
        data = data[: len(data) // 2]
    elif damage == "flip":  # inside the uv array's bytes: only the archive's CRC tells
        data[len(data) // 2] ^= 0xFF
    else:
        data = bytearray()
    f.write_bytes(bytes(data))
    with pytest.raises(CorruptArtifactError):
        artifact_from_bytes(bytes(data), key)
    got = prepare_key_cached(store, path, entries, 0, options=AUTO)
    assert got["meta"]["cache"]["state"] == "replaced"
    _assert_same(got, _fresh(path, entries, AUTO))
    assert prepare_key_cached(store, path, entries, 0, options=AUTO)["meta"]["cache"]["state"] == (
        "hit"
    )


def test_an_entry_under_another_key_is_refused(
    face: tuple[Path, list[Any]], tmp_path: Path
) -> None:
    path, entries = face
    store = DirectoryArtifactStore(tmp_path / "cache")
    a, info = cached_artifact(store, path, entries, 0, options=AUTO)
    other = key_artifact_key("0" * 64, "obj", AUTO)
    store.put(other, artifact_bytes(a))  # a's bytes under another key: never served
    with pytest.raises(CorruptArtifactError, match="another key"):
        artifact_from_bytes(store.get(other) or b"", other)


def test_concurrent_writers_leave_one_whole_entry(
    face: tuple[Path, list[Any]], tmp_path: Path
) -> None:
    path, entries = face
    store = DirectoryArtifactStore(tmp_path / "cache")
    a, info = cached_artifact(store, path, entries, 0, options=AUTO)
    data = artifact_bytes(a)
    seen: list[bytes | None] = []

    def write() -> None:
        for _ in range(20):
            store.put(info["key"], data)

    def read() -> None:
        for _ in range(40):
            seen.append(store.get(info["key"]))

    threads = [threading.Thread(target=f) for f in (write, write, write, read)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(s == data for s in seen)  # a reader sees a whole archive, never a part
    assert sorted(p.name for p in store.root.iterdir()) == [f"{info['key']}.npz"]
    np.testing.assert_array_equal(
        artifact_from_bytes(store.get(info["key"]) or b"", info["key"]).uv, a.uv
    )


def test_face_cut_entry_serves_only_its_landmarks(tmp_path: Path) -> None:
    from tests.meshes import closed_head

    V, F = closed_head()
    path = _write_obj(tmp_path / "head.obj", V, F)
    tip = int(np.argmax(V[:, 2]))
    near = np.argsort(np.linalg.norm(V - V[tip], axis=1))
    lm = [int(i) for i in near[:30:5]]
    store = DirectoryArtifactStore(tmp_path / "cache")
    first = prepare_key_cached(store, path, lm, 0, options=AUTO)
    assert "face_cut" in first["meta"]["preparation"]
    assert prepare_key_cached(store, path, lm, 0, options=AUTO)["meta"]["cache"]["state"] == "hit"
    moved = [int(i) for i in near[1:31:5]]  # other landmarks place the cut elsewhere
    got = prepare_key_cached(store, path, moved, 0, options=AUTO)
    assert got["meta"]["cache"]["state"] == "replaced"
    _assert_same(got, _fresh(path, moved, AUTO))


def test_default_cache_dir_follows_xdg(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_cache_dir() == tmp_path / "conformorph"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert default_cache_dir() == Path.home() / ".cache" / "conformorph"
