"""Artifact storage in an S3-compatible object store (``CONFORMORPH_STORAGE_URL=s3://…``).

Workers on several hosts cannot share a local volume: they share a bucket
instead. Objects live under ``s3://<bucket>/<prefix>/<key>``; the endpoint
and credentials come from the environment as boto3 reads them
(``AWS_ENDPOINT_URL``, ``AWS_ACCESS_KEY_ID``, ``AWS_SECRET_ACCESS_KEY``,
``AWS_DEFAULT_REGION``, …), or from ``CONFORMORPH_S3_ENDPOINT_URL`` and
``CONFORMORPH_S3_REGION``.

- **Writes are atomic**: a single PUT, or a multipart upload that the store
  makes visible only when it completes, so a reader never sees half an object.
  Files are uploaded in parts (``CONFORMORPH_S3_PART_BYTES``) straight from
  disk, never held whole in memory; every object carries its sha256 as
  metadata (the ETag the API serves). Bytes that this storage has just put
  under another key (an upload kept under its final key after validation) are
  copied inside the store instead of being sent again.
- **Reads stream**: :meth:`S3Storage.open` returns a seekable reader that asks
  for byte ranges as it goes (the artifact routes' Range requests cost one
  ranged GET).
- **Numerics read files**: :meth:`S3Storage.local_path` downloads the object
  into a local cache named by its sha256 (so a cached copy is never stale),
  and a file moved into storage is kept there as the cached copy, so the next
  stage on the same host does not download it again. The cache is trimmed to
  ``CONFORMORPH_S3_CACHE_MAX_BYTES``, least recently used first.
- **Downloads** are streamed by the API, or (``CONFORMORPH_S3_DOWNLOADS=redirect``)
  answered with a redirect to a presigned URL (:meth:`S3Storage.download_url`).

boto3 is imported when an :class:`S3Storage` is made (``pip install
'conformorph[s3]'``); the local filesystem stays the default storage.
"""

from __future__ import annotations

import hashlib
import io
import logging
import os
import shutil
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, Literal
from urllib.parse import urlsplit

from conformorph.worker.storage import (
    ArtifactNotFound,
    StorageUnavailable,
    StoredObject,
    check_key,
    sha256_file,
)

log = logging.getLogger(__name__)
_SHA_META = "sha256"  # x-amz-meta-sha256
_MAX_COPY_BYTES = 5 << 30  # the largest object one CopyObject copies
_NOT_FOUND = {"404", "NoSuchKey", "NotFound", "NoSuchBucket"}
#: a cached copy used this recently is never evicted (a stage may be about to open it)
_CACHE_MIN_AGE = 120.0


class StorageConfigError(ValueError):
    """The storage URL or its settings are unusable (wrong scheme, no bucket, no boto3)."""


@dataclass(frozen=True)
class S3Options:
    """Where and how objects are stored; mapped from the settings by :func:`s3_options`.

    Attributes
    ----------
    bucket, prefix : str
        Objects are stored under ``<prefix>/<key>`` in ``bucket`` (no prefix: at the top).
    endpoint_url : str or None
        The store's endpoint (None: boto3's own choice, ``AWS_ENDPOINT_URL`` or AWS).
    public_endpoint_url : str or None
        The endpoint written into presigned URLs, when clients reach the store by
        another address than the service does (None: ``endpoint_url``).
    region : str or None
        The region (None: boto3's, ``AWS_DEFAULT_REGION``).
    addressing_style : {"auto", "path", "virtual"}
        Bucket in the path (MinIO, moto, most self-hosted stores) or in the host name.
    downloads : {"proxy", "redirect"}
        Artifact downloads streamed by the API, or redirected to a presigned URL.
    presign_seconds : int
        Lifetime of a presigned URL.
    cache_dir : Path
        Local copies of objects read by path, and the staging folder.
    cache_max_bytes : int
        The cache is trimmed to this size (least recently used first).
    part_bytes : int
        Multipart uploads and downloads go in parts of this size (at least 5 MiB).
    """

    bucket: str
    prefix: str
    cache_dir: Path
    endpoint_url: str | None = None
    public_endpoint_url: str | None = None
    region: str | None = None
    addressing_style: Literal["auto", "path", "virtual"] = "auto"
    downloads: Literal["proxy", "redirect"] = "proxy"
    presign_seconds: int = 300
    cache_max_bytes: int = 2 << 30
    part_bytes: int = 8 << 20

    def __post_init__(self) -> None:
        if self.part_bytes < 5 << 20:
            raise StorageConfigError("S3 part size must be at least 5 MiB (the S3 minimum)")
        if not 1 <= self.presign_seconds <= 7 * 24 * 3600:
            raise StorageConfigError("presigned URL lifetime must be 1 s to 7 days")


def parse_storage_url(url: str) -> tuple[str, str]:
    """``s3://bucket/some/prefix`` → ``("bucket", "some/prefix")``.

    Raises :class:`StorageConfigError` for another scheme, a missing bucket or an
    unsafe prefix.
    """
    parts = urlsplit(url)
    if parts.scheme.lower() != "s3":
        raise StorageConfigError(f"storage URL {url!r}: expected s3://bucket/prefix")
    bucket = parts.netloc
    if not bucket or parts.query or parts.fragment:
        raise StorageConfigError(f"storage URL {url!r}: expected s3://bucket/prefix")
    prefix = parts.path.strip("/")
    if prefix:
        try:
            check_key(prefix)
        except ValueError as exc:
            raise StorageConfigError(f"storage URL {url!r}: unsafe prefix {prefix!r}") from exc
    return bucket, prefix


def _not_found(exc: Exception) -> bool:
    code = str(getattr(exc, "response", {}).get("Error", {}).get("Code", ""))
    return code in _NOT_FOUND


#: error codes by which a store says "not now" (besides any 5xx status)
_UNAVAILABLE_CODES = {"SlowDown", "ServiceUnavailable", "InternalError", "RequestTimeout"}


def store_unavailable(exc: BaseException) -> bool:
    """True when ``exc`` (or what it wraps) says the store cannot be reached now.

    A botocore connection failure (refused, reset, timed out: its ``HTTPClientError``
    family), or the store's own answer with a 5xx status or a "slow down" code. Errors
    that are the request's fault (404, 403, a bad key) are not.
    """
    from botocore.exceptions import HTTPClientError

    seen: BaseException | None = exc
    for _ in range(6):  # boto3's transfer errors wrap the client's
        if seen is None:
            return False
        if isinstance(seen, HTTPClientError | ConnectionError | TimeoutError):
            return True
        meta = getattr(seen, "response", None)
        if isinstance(meta, dict):
            status = meta.get("ResponseMetadata", {}).get("HTTPStatusCode")
            code = str(meta.get("Error", {}).get("Code", ""))
            return (isinstance(status, int) and status >= 500) or code in _UNAVAILABLE_CODES
        seen = seen.__cause__ or seen.__context__
    return False


class _GuardedClient:
    """A boto3 client whose calls raise :class:`StorageUnavailable` when the store is
    down (see :func:`store_unavailable`), and anything else as they did."""

    def __init__(self, client: Any, where: str) -> None:
        self._client, self._where = client, where

    def __getattr__(self, name: str) -> Any:
        attr = getattr(self._client, name)
        if not callable(attr) or name == "get_paginator":
            return attr

        def call(*args: Any, **kwargs: Any) -> Any:
            try:
                return attr(*args, **kwargs)
            except StorageUnavailable:
                raise
            except Exception as exc:
                if store_unavailable(exc):
                    raise StorageUnavailable(
                        f"the object store {self._where} cannot be reached ({name})"
                    ) from exc
                raise

        return call


class _RangeReader(io.RawIOBase):
    """A seekable, streaming reader of one object: each read continues one ranged GET,
    and a seek starts the next one where it lands."""

    def __init__(self, client: Any, bucket: str, key: str, size: int, etag: str) -> None:
        self._client, self._bucket, self._key, self._size = client, bucket, key, size
        self._etag = etag  # every range of the same version (412 if it was replaced)
        self._pos = 0
        self._body: Any = None

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def tell(self) -> int:
        return self._pos

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._pos, io.SEEK_END: self._size}[whence]
        pos = base + offset
        if pos < 0:
            raise ValueError(f"negative seek position {pos}")
        if pos != self._pos:
            self._drop_body()
            self._pos = pos
        return self._pos

    def readinto(self, buffer: Any) -> int:
        view = memoryview(buffer).cast("B")
        if self._pos >= self._size or len(view) == 0:
            return 0
        if self._body is None:
            got = self._client.get_object(
                Bucket=self._bucket, Key=self._key, Range=f"bytes={self._pos}-", IfMatch=self._etag
            )
            self._body = got["Body"]
        data = self._body.read(len(view))
        if not data:  # the connection ended before the object did
            self._drop_body()
            raise OSError(f"{self._key}: stream ended at byte {self._pos} of {self._size}")
        view[: len(data)] = data
        self._pos += len(data)
        return len(data)

    def _drop_body(self) -> None:
        if self._body is not None:
            self._body.close()
            self._body = None

    def close(self) -> None:
        self._drop_body()
        super().close()


class S3Storage:
    """The :class:`conformorph.worker.storage.Storage` protocol on an S3-compatible bucket."""

    def __init__(self, options: S3Options) -> None:
        try:
            import boto3
            from boto3.s3.transfer import TransferConfig
            from botocore.config import Config
        except ImportError as exc:  # pragma: no cover - boto3 is a test dependency
            raise StorageConfigError(
                "s3:// storage needs boto3: pip install 'conformorph[s3]'"
            ) from exc
        self.options = options
        session = boto3.session.Session()
        s3cfg = {"addressing_style": options.addressing_style}
        common = {"region_name": options.region, "endpoint_url": options.endpoint_url}
        self._s3 = _GuardedClient(
            session.client(
                "s3",
                **common,
                config=Config(
                    connect_timeout=5,
                    read_timeout=60,
                    retries={"max_attempts": 5, "mode": "standard"},
                    s3=s3cfg,
                ),
            ),
            f"s3://{options.bucket}",
        )
        # readiness answers fast: one attempt, short timeouts
        self._ping_s3 = session.client(
            "s3",
            **common,
            config=Config(connect_timeout=2, read_timeout=3, retries={"max_attempts": 1}, s3=s3cfg),
        )
        self._presign_s3 = session.client(
            "s3",
            region_name=options.region,
            endpoint_url=options.public_endpoint_url or options.endpoint_url,
            config=Config(signature_version="s3v4", s3=s3cfg),
        )
        self._transfer = TransferConfig(
            multipart_threshold=options.part_bytes,
            multipart_chunksize=options.part_bytes,
            max_concurrency=4,
            io_chunksize=256 << 10,
        )
        self._recent: dict[str, str] = {}  # sha256 -> full key (see _copied)
        self.cache_dir = Path(options.cache_dir).expanduser().resolve()
        (self.cache_dir / ".staging").mkdir(parents=True, exist_ok=True)
        (self.cache_dir / "sha256").mkdir(exist_ok=True)

    def __repr__(self) -> str:
        return f"S3Storage(s3://{self.options.bucket}/{self.options.prefix})"

    # -- keys
    def _full(self, key: str) -> str:
        check_key(key)
        return f"{self.options.prefix}/{key}" if self.options.prefix else key

    def _relative(self, full: str) -> str:
        return full[len(self.options.prefix) + 1 :] if self.options.prefix else full

    def _head(self, key: str) -> dict[str, Any]:
        try:
            head: dict[str, Any] = self._s3.head_object(
                Bucket=self.options.bucket, Key=self._full(key)
            )
        except Exception as exc:
            if _not_found(exc):
                raise ArtifactNotFound(key) from exc
            raise
        return head

    # -- writes
    def put_bytes(self, key: str, data: bytes) -> StoredObject:
        """Store ``data`` in one PUT (atomic) and keep a cached copy."""
        full = self._full(key)
        digest = hashlib.sha256(data).hexdigest()
        self._s3.put_object(
            Bucket=self.options.bucket, Key=full, Body=data, Metadata={_SHA_META: digest}
        )
        self._remember(digest, full)
        staged = self._staged_name()
        try:
            staged.write_bytes(data)
            self._adopt(staged, digest, key)
        finally:
            staged.unlink(missing_ok=True)
        return StoredObject(key, len(data), digest)

    def put_file(self, key: str, source: Path, *, move: bool = False) -> StoredObject:
        """Upload ``source`` in parts read from disk; with ``move`` the file becomes the
        cached copy (else it is left where it is)."""
        full = self._full(key)
        digest, size = sha256_file(Path(source))
        if not self._copied(full, digest):
            self._s3.upload_file(
                str(source),
                self.options.bucket,
                full,
                ExtraArgs={"Metadata": {_SHA_META: digest}},
                Config=self._transfer,
            )
        self._remember(digest, full)
        if move:
            self._adopt(Path(source), digest, key)
        return StoredObject(key, size, digest)

    def _remember(self, digest: str, full: str) -> None:
        """The last object this storage put with content ``digest`` (a few hundred)."""
        self._recent.pop(digest, None)
        self._recent[digest] = full
        while len(self._recent) > 256:
            self._recent.pop(next(iter(self._recent)))

    def _copied(self, full: str, digest: str) -> bool:
        """Store the same bytes again by a server-side copy of an object this storage
        put (an upload kept under its final key after validation is not sent twice);
        False when there is none (still with those bytes), and the caller uploads."""
        src = self._recent.get(digest)
        if src is None or src == full:
            return False
        try:
            head = self._s3.head_object(Bucket=self.options.bucket, Key=src)
            if head.get("Metadata", {}).get(_SHA_META) != digest:
                return False
            if int(head["ContentLength"]) > _MAX_COPY_BYTES:
                return False
            self._s3.copy_object(
                Bucket=self.options.bucket,
                Key=full,
                CopySource={"Bucket": self.options.bucket, "Key": src},
                CopySourceIfMatch=head["ETag"],  # the very version just checked
                ChecksumAlgorithm="CRC32",  # the copy's own, not the parts' composite
            )
        except Exception as exc:
            if getattr(exc, "response", None) is None:
                raise  # not the store's answer (connection, credentials): as an upload would
            # gone or replaced meanwhile (404, 412), or a store without this copy: upload
            log.info("server-side copy of %s refused (%s); uploading", src, exc)
            return False
        return True

    # -- reads
    def open(self, key: str) -> BinaryIO:
        """A seekable reader streaming the object by ranged GETs."""
        head = self._head(key)
        size, etag = int(head["ContentLength"]), str(head["ETag"])
        raw = _RangeReader(self._s3, self.options.bucket, self._full(key), size, etag)
        return io.BufferedReader(raw, buffer_size=1 << 20)

    def read_bytes(self, key: str) -> bytes:
        try:
            got = self._s3.get_object(Bucket=self.options.bucket, Key=self._full(key))
        except Exception as exc:
            if _not_found(exc):
                raise ArtifactNotFound(key) from exc
            raise
        data: bytes = got["Body"].read()
        return data

    def exists(self, key: str) -> bool:
        try:
            self._head(key)
        except ArtifactNotFound:
            return False
        return True

    def size(self, key: str) -> int:
        return int(self._head(key)["ContentLength"])

    def local_path(self, key: str) -> Path:
        """A local file with the object's bytes (downloaded once per content, in parts);
        raises :class:`ArtifactNotFound` if the object is absent."""
        head = self._head(key)
        digest = head.get("Metadata", {}).get(_SHA_META) or "etag-" + str(
            head.get("ETag", "")
        ).strip('"').replace("-", "_")
        path = self._cache_path(digest, key)
        if path.is_file():
            os.utime(path)  # recently used: the last to be evicted
            return path
        staged = self._staged_name()
        try:
            self._s3.download_file(
                self.options.bucket, self._full(key), str(staged), Config=self._transfer
            )
            return self._adopt(staged, digest, key)
        except Exception as exc:
            if _not_found(exc):
                raise ArtifactNotFound(key) from exc
            raise
        finally:
            staged.unlink(missing_ok=True)

    def staging_dir(self) -> Path:
        """A local folder for uploads being received and files being made."""
        return self.cache_dir / ".staging"

    # -- deletion and listing
    def delete(self, key: str) -> None:
        self._s3.delete_object(Bucket=self.options.bucket, Key=self._full(key))

    def delete_prefix(self, prefix: str) -> None:
        """Delete the object ``prefix`` and every object under ``prefix/`` (a page of
        up to 1000 keys per request)."""
        base = self._full(prefix.rstrip("/"))
        self._s3.delete_object(Bucket=self.options.bucket, Key=base)
        for page in self._pages(base + "/"):
            objects = [{"Key": k} for k in page]
            if objects:
                self._s3.delete_objects(
                    Bucket=self.options.bucket, Delete={"Objects": objects, "Quiet": True}
                )

    def iter_keys(self, prefix: str) -> Iterator[str]:
        """Keys under ``prefix/`` in key order (names starting with a dot left out,
        as the local storage leaves out its temporary files)."""
        for page in self._pages(self._full(prefix.rstrip("/")) + "/"):
            for full in page:
                key = self._relative(full)
                if not key.rsplit("/", 1)[-1].startswith("."):
                    yield key

    def _pages(self, start: str) -> Iterator[list[str]]:
        """The bucket's full keys that start with ``start``, a listing page at a time."""
        pages = iter(
            self._s3.get_paginator("list_objects_v2").paginate(
                Bucket=self.options.bucket, Prefix=start
            )
        )
        while True:
            try:
                page = next(pages)
            except StopIteration:
                return
            except Exception as exc:
                if store_unavailable(exc):
                    raise StorageUnavailable(
                        f"the object store s3://{self.options.bucket} cannot be reached (list)"
                    ) from exc
                raise
            yield [str(obj["Key"]) for obj in page.get("Contents", [])]

    def ping(self) -> bool:
        """True when the bucket answers to these credentials (HEAD bucket, ~3 s at most)."""
        try:
            self._ping_s3.head_bucket(Bucket=self.options.bucket)
        except Exception:  # noqa: BLE001 - any failure means "not reachable"
            return False
        return True

    def download_url(self, key: str, content_type: str) -> str | None:
        """A presigned GET URL of ``key`` (served with ``content_type``) when downloads
        are redirected, else None (the API streams the object itself)."""
        if self.options.downloads != "redirect":
            return None
        url: str = self._presign_s3.generate_presigned_url(
            "get_object",
            Params={
                "Bucket": self.options.bucket,
                "Key": self._full(key),
                "ResponseContentType": content_type,
            },
            ExpiresIn=self.options.presign_seconds,
        )
        return url

    # -- the local cache
    def _staged_name(self) -> Path:
        return self.staging_dir() / f".s3-{uuid.uuid4().hex}.tmp"

    def _cache_path(self, digest: str, key: str) -> Path:
        """``<cache>/sha256/<digest>/<the key's file name>`` (the suffix is kept: some
        readers go by it)."""
        return self.cache_dir / "sha256" / digest / key.rsplit("/", 1)[-1]

    def _adopt(self, source: Path, digest: str, key: str) -> Path:
        """Move ``source`` into the cache as the copy of content ``digest`` (a rename
        when it is on the cache's filesystem, as staged files are; the copy appears
        atomically), then trim the cache."""
        dest = self._cache_path(digest, key)
        dest.parent.mkdir(parents=True, exist_ok=True)
        tmp = dest.parent / f".{uuid.uuid4().hex}.tmp"
        try:
            try:
                os.replace(source, tmp)
            except OSError:  # another filesystem
                shutil.move(str(source), tmp)
            os.replace(tmp, dest)
        finally:
            tmp.unlink(missing_ok=True)
        self.trim_cache()
        return dest

    def trim_cache(self) -> int:
        """Remove cached copies, least recently used first, until the cache is within
        ``cache_max_bytes``; copies used in the last two minutes stay. Returns the
        bytes freed."""
        files = []
        for p in (self.cache_dir / "sha256").glob("*/*"):
            try:
                st = p.stat()
            except FileNotFoundError:
                continue
            if not p.name.startswith("."):
                files.append((st.st_mtime, st.st_size, p))
        total = sum(size for _, size, _ in files)
        freed = 0
        now = time.time()
        for mtime, size, p in sorted(files, key=lambda f: f[0]):
            if total - freed <= self.options.cache_max_bytes or now - mtime < _CACHE_MIN_AGE:
                break
            p.unlink(missing_ok=True)
            try:
                p.parent.rmdir()
            except OSError:
                pass  # another name of the same content is still cached
            freed += size
        return freed
