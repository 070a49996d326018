"""Artifact storage: a small key/value protocol and its local-filesystem implementation.

Keys are relative, ``/``-separated paths of safe characters
(``jobs/<job id>/<stage>-<param hash>/disk_map.npz``). Every write is atomic:
the bytes go to a temporary file in the destination folder, are flushed to
disk, and are renamed over the key, so a reader (or a task run twice after a
redelivery) never sees a half-written artifact. ``worker/s3_storage.py``
implements the same protocol on an S3-compatible object store, and
``worker/open_storage.py`` picks one from the settings.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import tempfile
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, Protocol, runtime_checkable

_KEY_RE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9._\-]*(/[A-Za-z0-9_][A-Za-z0-9._\-]*)*$")
_CHUNK = 1 << 20


class StorageKeyError(ValueError):
    """A storage key is malformed (absolute, ``..``, odd characters)."""


class ArtifactNotFound(LookupError):
    """No object is stored under the key."""


class StorageUnavailable(OSError):
    """The object store cannot be reached or answers that it cannot serve now (a
    connection refused or timed out, a 5xx): transient. The API answers 503 with
    ``Retry-After``; a stage is retried with back-off (``worker/tasks.py``)."""

    #: seconds a client is told to wait before trying again
    retry_after = 30


@dataclass(frozen=True)
class StoredObject:
    """What a write returns: the key, its size in bytes and a strong ETag (sha256)."""

    key: str
    size: int
    sha256: str


def check_key(key: str) -> str:
    """Return ``key`` if it is a safe relative key, else raise :class:`StorageKeyError`."""
    if not isinstance(key, str) or len(key) > 512 or not _KEY_RE.match(key) or ".." in key:
        raise StorageKeyError(f"invalid storage key {key!r}")
    return key


@runtime_checkable
class Storage(Protocol):
    """Put and get artifacts by key."""

    def put_bytes(self, key: str, data: bytes) -> StoredObject: ...

    def put_file(self, key: str, source: Path, *, move: bool = False) -> StoredObject: ...

    def open(self, key: str) -> BinaryIO: ...

    def read_bytes(self, key: str) -> bytes: ...

    def exists(self, key: str) -> bool: ...

    def size(self, key: str) -> int: ...

    def local_path(self, key: str) -> Path: ...

    def delete(self, key: str) -> None: ...

    def delete_prefix(self, prefix: str) -> None: ...

    def iter_keys(self, prefix: str) -> Iterator[str]: ...

    def staging_dir(self) -> Path: ...

    def ping(self) -> bool: ...


@runtime_checkable
class DirectDownloads(Protocol):
    """A storage that may hand clients a URL of their own (a presigned one)."""

    def download_url(self, key: str, content_type: str) -> str | None:
        """A URL serving ``key`` as ``content_type``, or None to stream it through the API."""
        ...


def sha256_file(path: Path) -> tuple[str, int]:
    """Return (hex sha256, size) of a file, read in chunks."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as f:
        while chunk := f.read(_CHUNK):
            h.update(chunk)
            size += len(chunk)
    return h.hexdigest(), size


class LocalStorage:
    """Storage in a folder of the local filesystem (shared volume in scale-out)."""

    def __init__(self, root: Path) -> None:
        self.root = Path(root).expanduser().resolve()
        self.root.mkdir(parents=True, exist_ok=True)
        (self.root / ".staging").mkdir(exist_ok=True)

    def _path(self, key: str) -> Path:
        return self.root / check_key(key)

    def staging_dir(self) -> Path:
        """A folder on the same filesystem as the artifacts (for renames)."""
        return self.root / ".staging"

    def local_path(self, key: str) -> Path:
        """The file holding ``key``; raises :class:`ArtifactNotFound` if absent."""
        p = self._path(key)
        if not p.is_file():
            raise ArtifactNotFound(key)
        return p

    def _tmp_for(self, dest: Path) -> Path:
        dest.parent.mkdir(parents=True, exist_ok=True)
        return dest.parent / f".{dest.name}.{uuid.uuid4().hex}.tmp"

    def put_bytes(self, key: str, data: bytes) -> StoredObject:
        dest = self._path(key)
        tmp = self._tmp_for(dest)
        try:
            with open(tmp, "wb") as f:
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, dest)
        finally:
            tmp.unlink(missing_ok=True)
        return StoredObject(key, len(data), hashlib.sha256(data).hexdigest())

    def put_file(self, key: str, source: Path, *, move: bool = False) -> StoredObject:
        dest = self._path(key)
        digest, size = sha256_file(Path(source))
        tmp = self._tmp_for(dest)
        try:
            if move:
                shutil.move(str(source), tmp)
            else:
                shutil.copyfile(source, tmp)
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
            os.replace(tmp, dest)
        finally:
            tmp.unlink(missing_ok=True)
        return StoredObject(key, size, digest)

    def open(self, key: str) -> BinaryIO:
        try:
            return open(self._path(key), "rb")
        except FileNotFoundError as exc:
            raise ArtifactNotFound(key) from exc

    def read_bytes(self, key: str) -> bytes:
        with self.open(key) as f:
            return f.read()

    def exists(self, key: str) -> bool:
        return self._path(key).is_file()

    def size(self, key: str) -> int:
        try:
            return self._path(key).stat().st_size
        except FileNotFoundError as exc:
            raise ArtifactNotFound(key) from exc

    def delete(self, key: str) -> None:
        self._path(key).unlink(missing_ok=True)

    def delete_prefix(self, prefix: str) -> None:
        p = self._path(prefix.rstrip("/"))
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)

    def iter_keys(self, prefix: str) -> Iterator[str]:
        base = self._path(prefix.rstrip("/"))
        if not base.is_dir():
            return
        for p in sorted(base.rglob("*")):
            if p.is_file() and not p.name.startswith("."):
                yield p.relative_to(self.root).as_posix()

    def ping(self) -> bool:
        """True when the root can be written (creates and removes a probe file)."""
        try:
            with tempfile.NamedTemporaryFile(dir=self.staging_dir()):
                return True
        except OSError:
            return False
