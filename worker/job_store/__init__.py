"""The job store: API keys, uploaded meshes and textures, jobs, through SQLAlchemy.

SQLite by default (WAL mode, so the API and the workers can share one file),
PostgreSQL by URL (``postgresql+psycopg://...``). The job row, not the Celery
result backend, is the truth about a job (celery #4450: ``PENDING`` means both
"waiting" and "unknown").

Leases
------
A running stage holds its job with ``lease_owner``/``lease_until`` and renews
the lease while it runs. Whoever finds a queued or running job whose lease has
run out (:meth:`JobStore.take_expired`) takes it with one conditional UPDATE,
so exactly one requeuer wins, and sends the job's remaining stages again. This
is how a job survives a SIGKILLed worker on the embedded broker, which never
redelivers; on Redis it is a second line behind redelivery. Stages write their
outputs atomically under deterministic keys and record completion in
``stages_done``, so running a stage twice is harmless.

Modules
-------
``tables`` (the ORM rows), ``views`` (the detached copies handed out), ``engine``
(SQLite/PostgreSQL connection and the per-owner job lock), ``base`` (sessions and
shared statements), ``keys`` (API keys), ``uploads`` (meshes, shapes, landmark sets,
textures), ``jobs`` (job rows and the atomic active-job limit), ``leases`` (stage
claims, renewals, completion, requeue takeover), ``stats`` (counts for monitoring), ``callbacks``
(webhook rows), ``retention`` (the cleanup of expired jobs and unused uploads),
``references`` (which uploads a job uses), ``key_artifacts`` (the stored per-mesh work of
uploaded meshes).
:class:`JobStore` is all of them.
"""

from __future__ import annotations

from conformorph.worker.job_store.callbacks import CallbackStore, CallbackView
from conformorph.worker.job_store.engine import make_engine
from conformorph.worker.job_store.jobs import InputGone, TooManyActiveJobs
from conformorph.worker.job_store.key_artifacts import KeyArtifactRows
from conformorph.worker.job_store.keys import KEY_PREFIX, KeyStore, hash_api_key
from conformorph.worker.job_store.leases import LeaseStore
from conformorph.worker.job_store.retention import CleanupReport, RetentionStore
from conformorph.worker.job_store.stats import JobStats, StatsStore
from conformorph.worker.job_store.tables import (
    ApiKey,
    Base,
    JobRecord,
    LandmarkSetRecord,
    MeshRecord,
    ShapeRecord,
    TextureRecord,
)
from conformorph.worker.job_store.uploads import UploadStore
from conformorph.worker.job_store.views import Claim, JobView, MeshView, TextureView

__all__ = [
    "KEY_PREFIX",
    "ApiKey",
    "Base",
    "CallbackView",
    "Claim",
    "CleanupReport",
    "JobRecord",
    "JobStats",
    "JobStore",
    "InputGone",
    "JobView",
    "LandmarkSetRecord",
    "MeshRecord",
    "MeshView",
    "ShapeRecord",
    "TextureRecord",
    "TextureView",
    "TooManyActiveJobs",
    "hash_api_key",
    "make_engine",
]


class JobStore(
    KeyStore,
    UploadStore,
    LeaseStore,
    StatsStore,
    CallbackStore,
    RetentionStore,
    KeyArtifactRows,
):
    """All persistent records of the service (see the module docstring)."""
