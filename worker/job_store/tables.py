"""The job store's tables (SQLAlchemy ORM): API keys, uploaded meshes, shapes,
landmark sets and textures (each scoped to its owner), and jobs."""

from __future__ import annotations

from typing import Any

from sqlalchemy import JSON, BigInteger, Float, Integer, String, Text, UniqueConstraint
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column


class Base(DeclarativeBase):
    pass


class ApiKey(Base):
    __tablename__ = "api_keys"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    key_hash: Mapped[str] = mapped_column(String(64), unique=True, index=True)
    created_at: Mapped[float] = mapped_column(Float)


class _ValidatedFile:
    """Columns of an uploaded file a worker validated (the layout of :class:`MeshView`)."""

    owner: Mapped[str] = mapped_column(String(64), primary_key=True)
    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    filename: Mapped[str] = mapped_column(String(300))
    file_type: Mapped[str] = mapped_column(String(16))
    storage_key: Mapped[str] = mapped_column(String(512))
    size_bytes: Mapped[int] = mapped_column(Integer)
    report: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[float] = mapped_column(Float)


class MeshRecord(_ValidatedFile, Base):
    """An uploaded 3D mesh."""

    __tablename__ = "meshes"


class ShapeRecord(_ValidatedFile, Base):
    """An uploaded 2D shape (JSON rings or SVG) for ``/v1/morphs2d``."""

    __tablename__ = "shapes"


class LandmarkSetRecord(Base):
    """An uploaded landmark document (any layout ``conformorph.pipelines.landmarks_io`` reads)."""

    __tablename__ = "landmark_sets"

    owner: Mapped[str] = mapped_column(String(64), primary_key=True)
    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    data: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[float] = mapped_column(Float)


class TextureRecord(Base):
    __tablename__ = "textures"

    owner: Mapped[str] = mapped_column(String(64), primary_key=True)
    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    filename: Mapped[str] = mapped_column(String(300))
    content_type: Mapped[str] = mapped_column(String(64))
    storage_key: Mapped[str] = mapped_column(String(512))
    size_bytes: Mapped[int] = mapped_column(Integer)
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[float] = mapped_column(Float)


class KeyArtifactRecord(Base):
    """A stored key artifact (an uploaded mesh's per-mesh work, see
    :mod:`conformorph.pipelines.face_morph.key_artifact`): counted in its owner's storage
    and deleted with its mesh."""

    __tablename__ = "key_artifacts"

    owner: Mapped[str] = mapped_column(String(64), primary_key=True)
    storage_key: Mapped[str] = mapped_column(String(512), primary_key=True)
    mesh_id: Mapped[str] = mapped_column(String(64), index=True)
    size_bytes: Mapped[int] = mapped_column(BigInteger)
    created_at: Mapped[float] = mapped_column(Float)


class JobRecord(Base):
    __tablename__ = "jobs"
    __table_args__ = (UniqueConstraint("owner", "idempotency_key", name="uq_jobs_idem"),)

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    owner: Mapped[str] = mapped_column(String(64), index=True)
    kind: Mapped[str] = mapped_column(String(32))
    state: Mapped[str] = mapped_column(String(16), index=True)
    stage: Mapped[str | None] = mapped_column(String(32), nullable=True)
    stages: Mapped[list[str]] = mapped_column(JSON)
    stages_done: Mapped[list[str]] = mapped_column(JSON)
    stage_seconds: Mapped[dict[str, float]] = mapped_column(JSON)
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    params: Mapped[dict[str, Any]] = mapped_column(JSON)
    error: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    artifacts: Mapped[dict[str, dict[str, Any]]] = mapped_column(JSON)
    idempotency_key: Mapped[str | None] = mapped_column(String(200), nullable=True)
    created_at: Mapped[float] = mapped_column(Float)
    started_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    finished_at: Mapped[float | None] = mapped_column(Float, nullable=True)
    updated_at: Mapped[float] = mapped_column(Float)
    lease_owner: Mapped[str | None] = mapped_column(String(200), nullable=True)
    lease_until: Mapped[float | None] = mapped_column(Float, nullable=True, index=True)
    task_id: Mapped[str | None] = mapped_column(String(64), nullable=True)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    requeues: Mapped[int] = mapped_column(Integer, default=0)


class CallbackRecord(Base):
    """A job's webhook (``callback_url``): where, the secret it is signed with (never
    shown), its delivery status and every attempt."""

    __tablename__ = "job_callbacks"

    job_id: Mapped[str] = mapped_column(String(32), primary_key=True)
    owner: Mapped[str] = mapped_column(String(64), index=True)
    url: Mapped[str] = mapped_column(String(2048))
    #: the signing secret, encrypted (``fernet:…``, :mod:`conformorph.worker.secret_box`);
    #: rows written before encryption hold it in plaintext until a worker seals them
    secret: Mapped[str | None] = mapped_column(Text, nullable=True)
    #: pending (waiting for a terminal state or a retry), delivered, failed
    status: Mapped[str] = mapped_column(String(16), index=True)
    attempts: Mapped[list[dict[str, Any]]] = mapped_column(JSON)
    #: when the next dispatch is due (the sweeper sends it; a retry pushes it later)
    next_attempt_at: Mapped[float] = mapped_column(Float, index=True)
    created_at: Mapped[float] = mapped_column(Float)


class ExpiredUpload(Base):
    """An upload the retention cleanup deleted, remembered (without its content) so that
    a job naming it is told ``input_expired``, not ``not_found``; forgotten after
    ``EXPIRED_UPLOAD_MEMORY_SECONDS``."""

    __tablename__ = "expired_uploads"

    owner: Mapped[str] = mapped_column(String(64), primary_key=True)
    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    expired_at: Mapped[float] = mapped_column(Float, index=True)


class CleanupTotal(Base):
    """What the retention cleanup freed since the store was created, by ``what``
    (``jobs``, ``uploads``, ``bytes``); read by the API's metrics."""

    __tablename__ = "cleanup_totals"

    what: Mapped[str] = mapped_column(String(32), primary_key=True)
    total: Mapped[int] = mapped_column(BigInteger, default=0)
