"""The artifact storage that the settings name: the local folder, or an S3 bucket."""

from __future__ import annotations

from conformorph.worker.config import WorkerSettings
from conformorph.worker.s3_storage import S3Options, S3Storage, parse_storage_url
from conformorph.worker.storage import LocalStorage, Storage


def s3_options(settings: WorkerSettings, url: str) -> S3Options:
    """The S3 storage options of ``settings`` (every ``CONFORMORPH_S3_*`` setting,
    mapped here only) for the storage URL ``url``."""
    bucket, prefix = parse_storage_url(url)
    return S3Options(
        bucket=bucket,
        prefix=prefix,
        cache_dir=settings.resolved_s3_cache_dir,
        # an empty setting (compose's ${VAR:-}) is no setting
        endpoint_url=settings.s3_endpoint_url or None,
        public_endpoint_url=settings.s3_public_endpoint_url or None,
        region=settings.s3_region or None,
        addressing_style=settings.s3_addressing_style,
        downloads=settings.s3_downloads,
        presign_seconds=settings.s3_presign_seconds,
        cache_max_bytes=settings.s3_cache_max_bytes,
        part_bytes=settings.s3_part_bytes,
    )


def open_storage(settings: WorkerSettings) -> Storage:
    """``CONFORMORPH_STORAGE_URL=s3://bucket/prefix``: an :class:`S3Storage`; unset: the
    :class:`LocalStorage` in ``storage_dir`` (the default).

    Raises
    ------
    conformorph.worker.s3_storage.StorageConfigError
        The URL is not ``s3://bucket[/prefix]``, a setting is out of range, or boto3
        is not installed.
    """
    if settings.storage_url:
        return S3Storage(s3_options(settings, settings.storage_url))
    return LocalStorage(settings.resolved_storage_dir)


def describe_storage(settings: WorkerSettings) -> str:
    """Where the artifacts are, for start-up logs (no credentials: they are not in it)."""
    if settings.storage_url:
        return settings.storage_url
    return str(settings.resolved_storage_dir)
