"""Settings shared by the API and the workers (pydantic-settings).

Every setting comes from an environment variable prefixed ``CONFORMORPH_``
(for example ``CONFORMORPH_DATA_DIR``, ``CONFORMORPH_BROKER_URL``). With no
broker URL the *embedded* set-up is used: kombu's filesystem transport and a
SQLite result store, all under ``data_dir``, so that one command runs the
whole service without any server. The broker URL may name Redis
(``redis://host:6379/0``, results in Redis too) or RabbitMQ
(``amqp://user:password@host:5672//``, results in the SQL database: the job
store's when it is a server database, else ``celery-results.sqlite``).

The API's own settings (limits, keys) extend this class in
``service/core/config.py``; the worker never imports the service.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Literal
from urllib.parse import urlsplit

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict


def default_data_dir() -> Path:
    """``$XDG_DATA_HOME/conformorph`` (``~/.local/share/conformorph``)."""
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "conformorph"


class WorkerSettings(BaseSettings):
    """Where state lives and how jobs are run."""

    model_config = SettingsConfigDict(env_prefix="CONFORMORPH_", extra="ignore")

    data_dir: Path = Field(default_factory=default_data_dir)
    #: SQLAlchemy URL of the job store; default ``sqlite:///<data_dir>/jobs.sqlite``
    database_url: str | None = None
    #: Celery broker; default: the embedded filesystem broker under ``data_dir``
    broker_url: str | None = None
    #: Celery result store; default ``db+sqlite:///<data_dir>/celery-results.sqlite``
    #: with the embedded broker, the broker URL for Redis
    result_backend: str | None = None
    #: artifact root of the local filesystem storage; default ``<data_dir>/artifacts``
    storage_dir: Path | None = None
    #: artifacts in an S3-compatible object store instead: ``s3://bucket/prefix``
    #: (``worker/s3_storage.py``; credentials from boto3's environment, AWS_*)
    storage_url: str | None = None
    #: the object store's endpoint (default: boto3's, ``AWS_ENDPOINT_URL`` or AWS)
    s3_endpoint_url: str | None = None
    #: the endpoint put into presigned URLs, when clients reach the store by
    #: another address than the service; default ``s3_endpoint_url``
    s3_public_endpoint_url: str | None = None
    #: the region (default: boto3's, ``AWS_DEFAULT_REGION``)
    s3_region: str | None = None
    #: ``path`` (MinIO and most self-hosted stores), ``virtual`` or ``auto``
    s3_addressing_style: Literal["auto", "path", "virtual"] = "auto"
    #: artifact downloads streamed by the API (``proxy``) or answered with a 307 to
    #: a presigned URL (``redirect``)
    s3_downloads: Literal["proxy", "redirect"] = "proxy"
    #: lifetime of a presigned download URL
    s3_presign_seconds: int = 300
    #: local copies of objects that the numerics read as files, and the staging
    #: folder of uploads; default ``<data_dir>/s3-cache``
    s3_cache_dir: Path | None = None
    #: the cache is trimmed to this size, least recently used first
    s3_cache_max_bytes: int = 2 << 30
    #: multipart upload/download part size (at least 5 MiB)
    s3_part_bytes: int = 8 << 20

    #: a running stage holds its job for this long and renews it every third of it
    lease_seconds: float = 30.0
    #: a queued job whose first stage has not started after this long is re-sent
    queued_requeue_seconds: float = 900.0
    #: requeue jobs whose lease ran out (the job store's own redelivery)
    lease_requeue: bool = True
    #: how often each worker looks for expired leases
    requeue_check_seconds: float = 2.0
    #: a job whose worker was lost this many times is failed
    max_attempts: int = 4

    task_soft_time_limit: float = 900.0
    task_hard_time_limit: float = 960.0
    #: Redis visibility timeout: longer than the hard time limit (celery #5306)
    redis_visibility_timeout: float = 3600.0
    #: how often a Redis worker looks for unacknowledged messages older than the
    #: visibility timeout (a SIGKILLed worker's) to restore them; kombu's default
    #: is once every ~100 s
    redis_restore_interval: float = 10.0
    #: expiry of kombu's restore mutex (its default: 300 s). A worker SIGKILLed
    #: while it holds the mutex (it takes it at every restore check) leaves it
    #: behind, and no worker restores anything until it expires; a restore scan
    #: takes milliseconds, so a short expiry loses nothing
    redis_unacked_mutex_expire: float = 10.0
    #: the RabbitMQ server's ``consumer_timeout`` in seconds (its default: 30 min). A
    #: delivery left unacknowledged longer makes RabbitMQ close the worker's channel,
    #: and late acknowledgement holds a stage's message until the stage ends, so the
    #: hard time limit must stay below it (checked); raise both together (the
    #: server's ``consumer_timeout`` is in milliseconds in rabbitmq.conf)
    amqp_consumer_timeout: float = 1800.0
    #: Celery results (only the synchronous validation uses them) expire after this
    result_expires_seconds: float = 3600.0
    #: polling interval of the embedded broker
    embedded_polling_interval: float = 0.05

    #: webhooks (worker/callbacks.py): comma-separated allow-list of callback
    #: destinations: ``public`` (any globally routable address), host names, addresses
    #: or CIDR networks; empty: ``public`` only (no private, loopback, link-local …)
    callback_allow: str = ""
    #: seconds one webhook POST may take (connect, send, answer)
    callback_timeout: float = 10.0
    #: most delivery attempts of one webhook (the first included)
    callback_max_attempts: Annotated[int, Field(ge=1, le=50)] = 6
    #: wait before the first retry; each further retry waits twice as long
    callback_backoff_seconds: Annotated[float, Field(gt=0)] = 2.0
    #: a webhook sent to a worker that did not record its attempt is sent again after this
    callback_redispatch_seconds: Annotated[float, Field(gt=0)] = 300.0
    #: server key encrypting webhook secrets at rest (worker/secret_box.py): a Fernet key
    #: or a passphrase, the same on the API and every worker; unset: the data directory's
    #: ``secret.key``, made on first use (one host)
    secret_key: str | None = Field(default=None, repr=False)

    #: retention (worker/retention.py): a finished job and its artifacts are deleted
    #: this long after it ended (0: kept forever)
    job_retention_seconds: float = 7 * 24 * 3600.0
    #: an upload (mesh, shape, texture, landmark set) no queued or running job uses, and
    #: no job created within this long used, is deleted (0: kept forever)
    upload_retention_seconds: float = 7 * 24 * 3600.0
    #: how often the cleanup runs (Celery beat, or ``conformorph serve``'s timer)
    cleanup_interval_seconds: Annotated[float, Field(gt=0)] = 3600.0

    def model_post_init(self, __context: object) -> None:
        self.data_dir = self.data_dir.expanduser().resolve()

    @property
    def is_embedded(self) -> bool:
        """True when no broker URL is configured (filesystem broker)."""
        return not self.broker_url

    @property
    def broker_scheme(self) -> str:
        """The broker URL's scheme (``filesystem`` for the embedded broker)."""
        return urlsplit(self.resolved_broker_url).scheme.lower()

    @property
    def is_amqp(self) -> bool:
        """True for a RabbitMQ (AMQP 0-9-1) broker URL."""
        return self.broker_scheme in ("amqp", "amqps", "pyamqp")

    @property
    def resolved_database_url(self) -> str:
        return self.database_url or f"sqlite:///{self.data_dir / 'jobs.sqlite'}"

    @property
    def resolved_storage_dir(self) -> Path:
        return (self.storage_dir or self.data_dir / "artifacts").expanduser().resolve()

    @property
    def resolved_s3_cache_dir(self) -> Path:
        return (self.s3_cache_dir or self.data_dir / "s3-cache").expanduser().resolve()

    @property
    def broker_dir(self) -> Path:
        return self.data_dir / "broker"

    @property
    def resolved_broker_url(self) -> str:
        return self.broker_url or "filesystem://"

    @property
    def resolved_result_backend(self) -> str:
        if self.result_backend:
            return self.result_backend
        if self.is_amqp and self.database_url and not self.database_url.startswith("sqlite"):
            return f"db+{self.database_url}"  # shared by every host, as the job store is
        if self.is_embedded or self.is_amqp:
            return f"db+sqlite:///{self.data_dir / 'celery-results.sqlite'}"
        return self.resolved_broker_url


@lru_cache
def get_worker_settings() -> WorkerSettings:
    """Settings read once from the environment."""
    return WorkerSettings()
