"""S3 artifact storage against moto's S3 server (a real HTTP endpoint on 127.0.0.1):
atomic puts, missing keys, delete/delete_prefix/iter_keys, ping, presigned URLs,
the local cache, and a big file streamed both ways in bounded memory."""

from __future__ import annotations

import hashlib
import os
import threading
import time
import tracemalloc
from pathlib import Path

import httpx
import pytest

from conformorph.worker.config import WorkerSettings
from conformorph.worker.open_storage import describe_storage, open_storage
from conformorph.worker.s3_storage import (
    S3Options,
    S3Storage,
    StorageConfigError,
    parse_storage_url,
)
from conformorph.worker.storage import (
    ArtifactNotFound,
    DirectDownloads,
    LocalStorage,
    Storage,
    StorageKeyError,
)
from tests.s3_server import AWS_TEST_ENV, S3Endpoint

MiB = 1 << 20


@pytest.fixture
def aws_env(monkeypatch: pytest.MonkeyPatch) -> None:
    for k in ("AWS_ENDPOINT_URL", "AWS_PROFILE", "AWS_SESSION_TOKEN"):
        monkeypatch.delenv(k, raising=False)
    for k, v in AWS_TEST_ENV.items():
        monkeypatch.setenv(k, v)


def _storage(moto_s3: S3Endpoint, cache: Path, bucket: str, **kw: object) -> S3Storage:
    opts = {"prefix": "pre/fix", "endpoint_url": moto_s3.url, "addressing_style": "path", **kw}
    return S3Storage(S3Options(bucket=bucket, cache_dir=cache, **opts))  # type: ignore[arg-type]


@pytest.fixture
def st(moto_s3: S3Endpoint, tmp_path: Path, aws_env: None) -> S3Storage:
    return _storage(moto_s3, tmp_path / "cache", moto_s3.new_bucket())


def test_put_get_etag_and_where_the_object_is(st: S3Storage, moto_s3: S3Endpoint) -> None:
    assert isinstance(st, Storage) and isinstance(st, DirectDownloads)
    obj = st.put_bytes("jobs/j1/map-abc/disk_map.npz", b"hello")
    assert obj.size == 5 and obj.sha256 == hashlib.sha256(b"hello").hexdigest()
    assert st.read_bytes(obj.key) == b"hello" and st.size(obj.key) == 5 and st.exists(obj.key)
    # stored under the URL's prefix, with its sha256 as metadata
    head = moto_s3.client().head_object(
        Bucket=st.options.bucket, Key="pre/fix/jobs/j1/map-abc/disk_map.npz"
    )
    assert head["Metadata"]["sha256"] == obj.sha256
    st.put_bytes(obj.key, b"hello again")  # overwrite
    assert st.read_bytes(obj.key) == b"hello again"
    assert st.local_path(obj.key).read_bytes() == b"hello again"
    assert st.local_path(obj.key).name == "disk_map.npz"  # readers may go by the suffix
    with st.open(obj.key) as f:
        f.seek(6)
        assert f.read() == b"again"
        f.seek(0)
        assert f.read(5) == b"hello"
        f.seek(-3, os.SEEK_END)
        assert f.read(100) == b"ain" and f.read(1) == b""


def test_a_reader_keeps_to_the_version_it_opened(st: S3Storage) -> None:
    """Ranges of one open() come from one version: after an overwrite the next ranged
    GET fails (412) instead of mixing two versions' bytes."""
    key = "jobs/j/anim.glb"
    st.put_bytes(key, b"0" * (3 * MiB))
    with st.open(key) as f:
        assert f.read(4) == b"0000"  # the reader's buffer holds the first MiB
        st.put_bytes(key, b"1" * (3 * MiB))
        f.seek(2 * MiB)  # past the buffer: a new ranged GET
        with pytest.raises(Exception, match="PreconditionFailed|412"):
            f.read(2)
    with st.open(key) as f:
        f.seek(2 * MiB)
        assert f.read(2) == b"11"


def test_missing_keys(st: S3Storage) -> None:
    key = "jobs/none/x.bin"
    assert not st.exists(key)
    for read in (st.open, st.read_bytes, st.size, st.local_path):
        with pytest.raises(ArtifactNotFound):
            read(key)  # type: ignore[operator]
    st.delete(key)  # deleting what is not there is no error
    st.delete_prefix("jobs/none")
    assert list(st.iter_keys("jobs")) == []


@pytest.mark.parametrize("key", ["", "/etc/passwd", "../x", "a/../b", "a//b", "a/.hidden"])
def test_bad_keys_are_refused(st: S3Storage, key: str) -> None:
    with pytest.raises(StorageKeyError):
        st.put_bytes(key, b"x")
    with pytest.raises(StorageKeyError):
        st.exists(key)


def test_delete_delete_prefix_and_iter_keys(st: S3Storage, moto_s3: S3Endpoint) -> None:
    for k in ("jobs/j1/a.json", "jobs/j1/m-1/b.glb", "jobs/j10/c.json", "uploads/o/d.obj"):
        st.put_bytes(k, k.encode())
    # a temporary name (as the local storage's) is not listed
    moto_s3.client().put_object(Bucket=st.options.bucket, Key="pre/fix/jobs/j1/.tmp", Body=b"")
    assert list(st.iter_keys("jobs/j1")) == ["jobs/j1/a.json", "jobs/j1/m-1/b.glb"]
    assert list(st.iter_keys("jobs/j1/")) == ["jobs/j1/a.json", "jobs/j1/m-1/b.glb"]
    assert list(st.iter_keys("jobs")) == [
        "jobs/j1/a.json",
        "jobs/j1/m-1/b.glb",
        "jobs/j10/c.json",
    ]
    st.delete("jobs/j1/a.json")
    assert not st.exists("jobs/j1/a.json") and st.exists("jobs/j1/m-1/b.glb")
    st.delete_prefix("jobs/j1")  # not jobs/j10, which only starts with the same letters
    assert list(st.iter_keys("jobs")) == ["jobs/j10/c.json"]
    st.delete_prefix("uploads/o/d.obj")  # a single key, as LocalStorage deletes a file
    assert not st.exists("uploads/o/d.obj")
    raw = moto_s3.client().list_objects_v2(Bucket=st.options.bucket)
    assert [o["Key"] for o in raw["Contents"]] == ["pre/fix/jobs/j10/c.json"]


def test_delete_prefix_past_one_batch(st: S3Storage, moto_s3: S3Endpoint) -> None:
    """More keys than one DeleteObjects request takes (1000)."""
    client = moto_s3.client()
    n = 1003

    def put(lo: int, hi: int) -> None:
        c = moto_s3.client()
        for i in range(lo, hi):
            c.put_object(Bucket=st.options.bucket, Key=f"pre/fix/jobs/big/{i:05d}", Body=b"")

    threads = [threading.Thread(target=put, args=(i, min(n, i + 251))) for i in range(0, n, 251)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    st.put_bytes("jobs/keep/x", b"x")
    keys = list(st.iter_keys("jobs/big"))
    assert len(keys) == n and keys == sorted(keys)  # listed across pages
    st.delete_prefix("jobs/big")
    assert list(st.iter_keys("jobs")) == ["jobs/keep/x"]
    assert client.list_objects_v2(Bucket=st.options.bucket)["KeyCount"] == 1


def test_prefixes_keep_storages_apart(moto_s3: S3Endpoint, tmp_path: Path, aws_env: None) -> None:
    bucket = moto_s3.new_bucket()
    a = _storage(moto_s3, tmp_path / "a", bucket, prefix="one")
    b = _storage(moto_s3, tmp_path / "b", bucket, prefix="")
    a.put_bytes("jobs/j/x", b"a")
    assert not b.exists("jobs/j/x") and b.read_bytes("one/jobs/j/x") == b"a"
    b.delete_prefix("jobs")
    assert a.exists("jobs/j/x")


def test_puts_are_atomic_for_concurrent_readers(st: S3Storage, tmp_path: Path) -> None:
    """While a new version is uploaded in parts, readers see the old one or the new
    one, whole, never a mixture or a part."""
    key = "jobs/j/frames.bin"
    old, new = b"a" * (6 * MiB), b"b" * (11 * MiB)  # the new one goes in 2 parts
    st.put_bytes(key, old)
    src = tmp_path / "new.bin"
    src.write_bytes(new)
    seen: set[bytes] = set()
    done = threading.Event()

    def upload() -> None:
        try:
            st.put_file(key, src)
        finally:
            done.set()

    t = threading.Thread(target=upload)
    t.start()
    while not done.is_set():
        got = st.read_bytes(key)
        assert got in (old, new), (len(got), got[:1], got[-1:])
        seen.add(got[:1])
    t.join()
    assert st.read_bytes(key) == new and b"a" in seen
    assert src.exists()  # put_file without move leaves the source
    # nothing half-written is left in the staging folder or the cache
    left = [p for p in st.cache_dir.rglob("*") if p.is_file() and p.name.endswith(".tmp")]
    assert left == []


def test_the_same_bytes_again_are_copied_in_the_store(
    st: S3Storage, moto_s3: S3Endpoint, tmp_path: Path
) -> None:
    """The API keeps a validated upload under its final key: the bytes it just put
    under the pending key are copied by the store, not uploaded twice; a pending
    object replaced meanwhile is not copied."""
    small = _storage(moto_s3, tmp_path / "s", st.options.bucket, part_bytes=5 * MiB)
    staged = small.staging_dir() / "up.obj"
    staged.write_bytes(b"v" * (6 * MiB))  # an upload goes in 2 parts: ETag "…-2"
    small.put_file("uploads/o/pending.obj", staged, move=True)
    cached = small.local_path("uploads/o/pending.obj")
    obj = small.put_file("meshes/o/final.obj", cached, move=True)
    small.delete("uploads/o/pending.obj")
    head = moto_s3.client().head_object(Bucket=st.options.bucket, Key="pre/fix/meshes/o/final.obj")
    assert "-" not in str(head["ETag"])  # one CopyObject, not a multipart upload
    assert head["Metadata"]["sha256"] == obj.sha256
    assert small.read_bytes("meshes/o/final.obj") == b"v" * (6 * MiB)
    # the first object changed (or went) before the second put: uploaded, not copied
    src = tmp_path / "again.obj"
    src.write_bytes(b"w" * (6 * MiB))
    small.put_file("uploads/o/p2.obj", src)
    small.put_bytes("uploads/o/p2.obj", b"other")
    small.put_file("meshes/o/f2.obj", src)
    assert small.read_bytes("meshes/o/f2.obj") == b"w" * (6 * MiB)
    head = moto_s3.client().head_object(Bucket=st.options.bucket, Key="pre/fix/meshes/o/f2.obj")
    assert str(head["ETag"]).strip('"').endswith("-2")


def test_put_into_a_missing_bucket_fails_and_stores_nothing(
    moto_s3: S3Endpoint, tmp_path: Path, aws_env: None
) -> None:
    st = _storage(moto_s3, tmp_path / "c", "no-such-bucket-here")
    src = tmp_path / "x.obj"
    src.write_bytes(b"v 0 0 0\n")
    with pytest.raises(Exception, match="NoSuchBucket|does not exist"):
        st.put_file("meshes/o/x.obj", src, move=True)
    assert src.exists()  # not moved away: the caller still has it
    assert [p for p in st.cache_dir.rglob("*") if p.is_file()] == []


def test_ping(moto_s3: S3Endpoint, tmp_path: Path, st: S3Storage) -> None:
    assert st.ping()
    assert not _storage(moto_s3, tmp_path / "m", "no-such-bucket-here").ping()
    with __import__("socket").socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        dead = f"http://127.0.0.1:{s.getsockname()[1]}"
    t0 = time.monotonic()
    down = S3Storage(S3Options(bucket="b", prefix="", cache_dir=tmp_path / "d", endpoint_url=dead))
    assert not down.ping() and time.monotonic() - t0 < 10


def test_presigned_download_urls(moto_s3: S3Endpoint, tmp_path: Path, aws_env: None) -> None:
    bucket = moto_s3.new_bucket()
    proxied = _storage(moto_s3, tmp_path / "p", bucket)
    assert proxied.download_url("jobs/j/a.glb", "model/gltf-binary") is None
    public = moto_s3.url.replace("127.0.0.1", "localhost")
    st = _storage(moto_s3, tmp_path / "r", bucket, downloads="redirect", public_endpoint_url=public)
    st.put_bytes("jobs/j/a.glb", b"glTF0123456789")
    url = st.download_url("jobs/j/a.glb", "model/gltf-binary")
    assert url is not None and url.startswith(public + f"/{bucket}/pre/fix/jobs/j/a.glb?")
    r = httpx.get(url)  # no credentials: the signature is the permission
    assert r.status_code == 200 and r.content == b"glTF0123456789"
    assert r.headers["content-type"] == "model/gltf-binary"
    part = httpx.get(url, headers={"Range": "bytes=4-7"})
    assert part.status_code == 206 and part.content == b"0123"
    tampered = url.replace("a.glb", "b.glb")
    assert httpx.get(tampered).status_code == 403


def test_local_path_cache_is_named_by_content(
    moto_s3: S3Endpoint, tmp_path: Path, aws_env: None
) -> None:
    """Another host's cache downloads once per content and never serves stale bytes;
    a file moved into storage is this host's cached copy."""
    bucket = moto_s3.new_bucket()
    writer = _storage(moto_s3, tmp_path / "w", bucket)
    reader = _storage(moto_s3, tmp_path / "r", bucket)
    made = writer.staging_dir() / "made.obj"
    made.write_bytes(b"v 1 2 3\n")
    writer.put_file("jobs/j/s-1/mesh.obj", made, move=True)
    assert not made.exists()
    assert writer.local_path("jobs/j/s-1/mesh.obj").read_bytes() == b"v 1 2 3\n"
    first = reader.local_path("jobs/j/s-1/mesh.obj")
    assert first.read_bytes() == b"v 1 2 3\n" and reader.local_path("jobs/j/s-1/mesh.obj") == first
    writer.put_bytes("jobs/j/s-1/mesh.obj", b"v 4 5 6\n")  # a new version elsewhere
    second = reader.local_path("jobs/j/s-1/mesh.obj")
    assert second != first and second.read_bytes() == b"v 4 5 6\n"
    writer.delete("jobs/j/s-1/mesh.obj")
    with pytest.raises(ArtifactNotFound):
        reader.local_path("jobs/j/s-1/mesh.obj")


def test_cache_is_trimmed_least_recently_used_first(
    moto_s3: S3Endpoint, tmp_path: Path, aws_env: None
) -> None:
    st = _storage(moto_s3, tmp_path / "c", moto_s3.new_bucket(), cache_max_bytes=2500)
    paths = [
        st.local_path(st.put_bytes(f"jobs/j/{i}.bin", bytes([i]) * 1000).key) for i in range(3)
    ]
    old = time.time() - 3600
    for age, p in enumerate(paths):  # 0 used longest ago; none used in the last minutes
        os.utime(p, (old + age, old + age))
    assert st.trim_cache() == 1000
    assert [p.exists() for p in paths] == [False, True, True]
    assert st.local_path("jobs/j/0.bin").read_bytes() == b"\x00" * 1000  # fetched again
    # recently used copies stay even above the limit (a stage may be about to open one)
    assert st.trim_cache() == 0


def test_big_file_streams_both_ways_in_bounded_memory(
    moto_s3: S3Endpoint, tmp_path: Path, aws_env: None
) -> None:
    """A 48 MiB file goes up in 5 MiB parts, comes down to another host's cache and
    streams out of open(), with at most a fraction of it in memory at any time."""
    size = 48 * MiB
    src = tmp_path / "big.bin"
    h = hashlib.sha256()
    with open(src, "wb") as f:
        for i in range(size // MiB):
            block = hashlib.sha256(str(i).encode()).digest() * (MiB // 32)
            h.update(block)
            f.write(block)
    bucket = moto_s3.new_bucket()
    up = _storage(moto_s3, tmp_path / "up", bucket, part_bytes=5 * MiB)
    down = _storage(moto_s3, tmp_path / "down", bucket, part_bytes=5 * MiB)
    tracemalloc.start()
    try:
        obj = up.put_file("jobs/j/big.bin", src)
        _, peak_up = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        path = down.local_path("jobs/j/big.bin")
        _, peak_down = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        streamed = hashlib.sha256()
        with down.open("jobs/j/big.bin") as f:
            f.seek(MiB)
            while chunk := f.read(256 * 1024):
                streamed.update(chunk)
        _, peak_open = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert obj.size == size and obj.sha256 == h.hexdigest()
    head = moto_s3.client().head_object(Bucket=bucket, Key="pre/fix/jobs/j/big.bin")
    assert str(head["ETag"]).strip('"').endswith("-10")  # a multipart upload of 10 parts
    assert (
        path.stat().st_size == size and hashlib.sha256(path.read_bytes()).hexdigest() == obj.sha256
    )
    with open(src, "rb") as f:
        f.seek(MiB)
        assert streamed.hexdigest() == hashlib.sha256(f.read()).hexdigest()
    for peak in (peak_up, peak_down, peak_open):
        assert peak < size // 2, (peak_up, peak_down, peak_open)


def test_storage_chosen_by_url(tmp_path: Path, moto_s3: S3Endpoint, aws_env: None) -> None:
    local = WorkerSettings(data_dir=tmp_path)
    assert isinstance(open_storage(local), LocalStorage)
    assert describe_storage(local) == str(tmp_path / "artifacts")
    s3 = WorkerSettings(
        data_dir=tmp_path,
        storage_url="s3://bkt/a/b",
        s3_endpoint_url=moto_s3.url,
        s3_downloads="redirect",
        s3_part_bytes=6 * MiB,
    )
    st = open_storage(s3)
    assert isinstance(st, S3Storage) and describe_storage(s3) == "s3://bkt/a/b"
    assert (st.options.bucket, st.options.prefix, st.options.downloads) == (
        "bkt",
        "a/b",
        "redirect",
    )
    assert st.options.part_bytes == 6 * MiB and st.cache_dir == tmp_path / "s3-cache"
    assert st.staging_dir().is_dir()


@pytest.mark.parametrize(
    "url, expected",
    [("s3://b", ("b", "")), ("s3://b/", ("b", "")), ("S3://b/p/q/", ("b", "p/q"))],
)
def test_parse_storage_url(url: str, expected: tuple[str, str]) -> None:
    assert parse_storage_url(url) == expected


@pytest.mark.parametrize(
    "url", ["file:///data", "s3:///prefix", "s3://b/../x", "s3://b/p?x=1", "/data/artifacts"]
)
def test_bad_storage_urls_are_refused(url: str, tmp_path: Path) -> None:
    with pytest.raises(StorageConfigError, match="storage URL"):
        open_storage(WorkerSettings(data_dir=tmp_path, storage_url=url))


def test_bad_s3_options_are_refused(tmp_path: Path) -> None:
    with pytest.raises(StorageConfigError, match="5 MiB"):
        S3Options(bucket="b", prefix="", cache_dir=tmp_path, part_bytes=MiB)
    with pytest.raises(StorageConfigError, match="lifetime"):
        S3Options(bucket="b", prefix="", cache_dir=tmp_path, presign_seconds=0)
