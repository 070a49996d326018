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
"""

from __future__ import annotations

import copy
import hashlib
import secrets
import time
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from sqlalchemy import (
    JSON,
    ColumnElement,
    Float,
    Integer,
    Select,
    String,
    UniqueConstraint,
    bindparam,
    create_engine,
    event,
    func,
    or_,
    select,
    text,
    update,
)
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column, sessionmaker

from worker import names

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

KEY_PREFIX = "cm_"
_T = TypeVar("_T")
_V = TypeVar("_V", bound="DataclassInstance")


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
    """An uploaded landmark document (any layout ``pipelines.landmarks_io`` reads)."""

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


@dataclass(frozen=True)
class JobView:
    """A detached, read-only copy of a job row."""

    id: str
    owner: str
    kind: str
    state: str
    stage: str | None
    stages: list[str]
    stages_done: list[str]
    stage_seconds: dict[str, float]
    progress: float
    params: dict[str, Any]
    error: dict[str, Any] | None
    artifacts: dict[str, dict[str, Any]]
    idempotency_key: str | None
    created_at: float
    started_at: float | None
    finished_at: float | None
    updated_at: float
    lease_owner: str | None
    lease_until: float | None
    task_id: str | None
    attempts: int
    requeues: int

    @classmethod
    def of(cls, r: JobRecord) -> JobView:
        return _view(cls, r)

    @property
    def remaining_stages(self) -> list[str]:
        return [s for s in self.stages if s not in self.stages_done]


_JOB_BY_ID = select(JobRecord.__table__).where(JobRecord.__table__.c.id == bindparam("job_id"))


@dataclass(frozen=True)
class MeshView:
    owner: str
    id: str
    filename: str
    file_type: str
    storage_key: str
    size_bytes: int
    report: dict[str, Any]
    created_at: float

    @classmethod
    def of(cls, r: MeshRecord | ShapeRecord) -> MeshView:
        return _view(cls, r)


@dataclass(frozen=True)
class TextureView:
    owner: str
    id: str
    filename: str
    content_type: str
    storage_key: str
    size_bytes: int
    width: int
    height: int
    created_at: float

    @classmethod
    def of(cls, r: TextureRecord) -> TextureView:
        return _view(cls, r)


@dataclass(frozen=True)
class Claim:
    """Outcome of :meth:`JobStore.claim_stage`.

    ``status`` is ``"claimed"`` (run the stage), ``"done"`` (the stage already
    finished: move on), ``"busy"`` (another live worker holds the lease for
    ``wait`` more seconds) or ``"gone"`` (the job is finished, cancelled or
    deleted: drop the message).
    """

    status: str
    job: JobView | None
    wait: float = 0.0


def _view(cls: type[_V], row: Any) -> _V:
    """A detached copy of a row (ORM object or Core row) as the view dataclass ``cls``:
    every field of ``cls`` read from the row's attribute of the same name, JSON
    values (lists, dicts) copied so the view shares nothing with the session."""
    return cls(**{f.name: copy.deepcopy(getattr(row, f.name)) for f in fields(cls)})


def _ended(state: str, now: float) -> dict[str, Any]:
    """Column values of a job entering the terminal ``state`` at ``now`` (lease released)."""
    return {
        "state": state,
        "finished_at": now,
        "updated_at": now,
        "lease_owner": None,
        "lease_until": None,
    }


def _count(s: Session, model: type[Base], *where: ColumnElement[bool]) -> int:
    """``SELECT count(*) FROM model WHERE where``."""
    return int(s.scalar(select(func.count()).select_from(model).where(*where)) or 0)


def _newest_first(stmt: Select[Any], model: Any, limit: int, offset: int) -> Select[Any]:
    """One page of ``stmt``, newest ``created_at`` first (ties by id)."""
    return stmt.order_by(model.created_at.desc(), model.id).limit(limit).offset(offset)


def _present(value: _T | None) -> _T:
    """``value``, or RuntimeError when a row just written has vanished."""
    if value is None:
        raise RuntimeError("row vanished right after it was written")
    return value


def hash_api_key(key: str) -> str:
    """SHA-256 of an API key (keys are 256-bit random tokens, so no slow hash is needed)."""
    return hashlib.sha256(key.encode()).hexdigest()


def _sqlite_pragmas(dbapi_conn: Any, _record: Any) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.execute("PRAGMA busy_timeout=30000")
    cur.close()


def make_engine(url: str) -> Engine:
    """An engine for ``url``; SQLite gets WAL mode and a busy timeout."""
    if url.startswith("sqlite"):
        path = make_url(url).database
        if path and path != ":memory:":
            Path(path).expanduser().parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(url, connect_args={"timeout": 30, "check_same_thread": False})
        event.listen(engine, "connect", _sqlite_pragmas)
        return engine
    return create_engine(url, pool_pre_ping=True, pool_size=10, max_overflow=20)


class JobStore:
    """All persistent records of the service (see the module docstring)."""

    def __init__(self, url: str, *, create: bool = True) -> None:
        self.url = url
        self.engine = make_engine(url)
        self._sessions = sessionmaker(self.engine, expire_on_commit=False)
        if create:
            self.create_all()

    def create_all(self) -> None:
        Base.metadata.create_all(self.engine)

    def dispose(self) -> None:
        self.engine.dispose()

    @contextmanager
    def session(self) -> Iterator[Session]:
        with self._sessions() as s, s.begin():
            yield s

    def _get_owned(
        self, record: type[Base], view: type[_V], owner: str, record_id: str
    ) -> _V | None:
        """The view of the ``(owner, id)`` row of an owner-scoped table, or None."""
        with self.session() as s:
            r = s.get(record, (owner, record_id))
            return _view(view, r) if r else None

    def _insert_once(self, row: Base) -> None:
        """Insert ``row``; an existing row with the same primary key is kept as it is."""
        try:
            with self.session() as s:
                s.add(row)
        except IntegrityError:
            pass

    def _update_job(self, job_id: str, *where: ColumnElement[bool], **values: Any) -> bool:
        """``UPDATE jobs SET values WHERE id = job_id AND where``; True when the row matched."""
        with self.session() as s:
            res = s.execute(
                update(JobRecord)
                .where(JobRecord.id == job_id, *where)
                .values(**values)
                .execution_options(synchronize_session=False)
            )
            return bool(res.rowcount == 1)  # type: ignore[attr-defined]

    def ping(self) -> bool:
        try:
            with self.engine.connect() as c:
                c.execute(text("SELECT 1"))
            return True
        except Exception:  # noqa: BLE001 - readiness probe reports any failure
            return False

    # ---------------------------------------------------------------- keys
    def create_key(self, name: str) -> tuple[str, str]:
        """Create an API key; returns (key id, the plaintext key, shown once)."""
        if not name or len(name) > 200:
            raise ValueError("key name must be 1-200 characters")
        plain = KEY_PREFIX + secrets.token_urlsafe(32)
        kid = uuid.uuid4().hex[:16]
        with self.session() as s:
            s.add(ApiKey(id=kid, name=name, key_hash=hash_api_key(plain), created_at=time.time()))
        return kid, plain

    def count_keys(self) -> int:
        with self.session() as s:
            return _count(s, ApiKey)

    def key_id_for(self, plain: str) -> str | None:
        """The id of the key whose hash matches ``plain``, or None."""
        with self.session() as s:
            return s.scalar(select(ApiKey.id).where(ApiKey.key_hash == hash_api_key(plain)))

    # -------------------------------------------------------------- meshes
    def get_mesh(self, owner: str, mesh_id: str) -> MeshView | None:
        return self._get_owned(MeshRecord, MeshView, owner, mesh_id)

    def add_mesh(self, view: MeshView) -> MeshView:
        """Insert, or return the existing record with the same (owner, id)."""
        self._insert_once(MeshRecord(**asdict(view)))
        return _present(self.get_mesh(view.owner, view.id))

    def list_meshes(self, owner: str, *, limit: int = 50, offset: int = 0) -> list[MeshView]:
        with self.session() as s:
            stmt = select(MeshRecord).where(MeshRecord.owner == owner)
            rows = s.scalars(_newest_first(stmt, MeshRecord, limit, offset))
            return [MeshView.of(r) for r in rows]

    # -------------------------------------------------------------- shapes
    def get_shape(self, owner: str, shape_id: str) -> MeshView | None:
        return self._get_owned(ShapeRecord, MeshView, owner, shape_id)

    def add_shape(self, view: MeshView) -> MeshView:
        """Insert, or return the existing record with the same (owner, id)."""
        self._insert_once(ShapeRecord(**asdict(view)))
        return _present(self.get_shape(view.owner, view.id))

    # ------------------------------------------------------------ landmarks
    def get_landmarks(self, owner: str, set_id: str) -> tuple[dict[str, Any], float] | None:
        """(document, created_at) of an uploaded landmark set, or None."""
        with self.session() as s:
            r = s.get(LandmarkSetRecord, (owner, set_id))
            return (dict(r.data), r.created_at) if r else None

    def add_landmarks(self, owner: str, set_id: str, data: dict[str, Any]) -> float:
        """Store a landmark document (same id again: kept); returns its creation time."""
        self._insert_once(
            LandmarkSetRecord(owner=owner, id=set_id, data=data, created_at=time.time())
        )
        return _present(self.get_landmarks(owner, set_id))[1]

    # ------------------------------------------------------------ textures
    def get_texture(self, owner: str, tex_id: str) -> TextureView | None:
        return self._get_owned(TextureRecord, TextureView, owner, tex_id)

    def add_texture(self, view: TextureView) -> TextureView:
        """Insert, or return the existing record with the same (owner, id)."""
        self._insert_once(TextureRecord(**asdict(view)))
        return _present(self.get_texture(view.owner, view.id))

    # ---------------------------------------------------------------- jobs
    def create_job(
        self,
        *,
        owner: str,
        kind: str,
        params: dict[str, Any],
        idempotency_key: str | None = None,
        queued_lease_seconds: float = 900.0,
    ) -> tuple[JobView, bool]:
        """Create a queued job; returns (job, created). With an idempotency key
        already used by this owner, returns the existing job and False."""
        if idempotency_key is not None:
            existing = self.job_by_idempotency_key(owner, idempotency_key)
            if existing is not None:
                return existing, False
        now = time.time()
        jid = uuid.uuid4().hex
        try:
            with self.session() as s:
                s.add(
                    JobRecord(
                        id=jid,
                        owner=owner,
                        kind=kind,
                        state=names.QUEUED,
                        stage=None,
                        stages=list(names.KIND_STAGES[kind]),
                        stages_done=[],
                        stage_seconds={},
                        progress=0.0,
                        params=params,
                        error=None,
                        artifacts={},
                        idempotency_key=idempotency_key,
                        created_at=now,
                        updated_at=now,
                        lease_owner=None,
                        lease_until=now + queued_lease_seconds,
                        attempts=0,
                        requeues=0,
                    )
                )
        except IntegrityError:
            if idempotency_key is None:
                raise
            existing = self.job_by_idempotency_key(owner, idempotency_key)
            if existing is None:
                raise
            return existing, False
        return _present(self.get_job(jid)), True

    def job_by_idempotency_key(self, owner: str, key: str) -> JobView | None:
        with self.session() as s:
            r = s.scalar(
                select(JobRecord).where(JobRecord.owner == owner, JobRecord.idempotency_key == key)
            )
            return JobView.of(r) if r else None

    def get_job(self, job_id: str, owner: str | None = None) -> JobView | None:
        """The job, or None when absent or (with ``owner``) owned by someone else.

        A plain Core SELECT (no ORM session): this is the hot read of the API.
        """
        with self.engine.connect() as c:
            row = c.execute(_JOB_BY_ID, {"job_id": job_id}).first()
        if row is None or (owner is not None and row.owner != owner):
            return None
        return _view(JobView, row)

    def list_jobs(
        self,
        owner: str,
        *,
        state: str | None = None,
        limit: int = 50,
        offset: int = 0,
    ) -> tuple[list[JobView], int]:
        """A page of the owner's jobs, newest first, and the total count."""
        with self.session() as s:
            cond = [JobRecord.owner == owner]
            if state is not None:
                cond.append(JobRecord.state == state)
            total = _count(s, JobRecord, *cond)
            rows = s.scalars(
                _newest_first(select(JobRecord).where(*cond), JobRecord, limit, offset)
            )
            return [JobView.of(r) for r in rows], total

    def count_active(self, owner: str) -> int:
        with self.session() as s:
            return _count(
                s, JobRecord, JobRecord.owner == owner, JobRecord.state.in_(names.ACTIVE_STATES)
            )

    def claim_stage(
        self, job_id: str, stage: str, worker_id: str, lease_seconds: float, task_id: str | None
    ) -> Claim:
        """Take the job's lease to run ``stage`` (see :class:`Claim`)."""
        now = time.time()
        job = self.get_job(job_id)
        if job is None or job.state in names.TERMINAL_STATES:
            return Claim("gone", job)
        if stage in job.stages_done:
            return Claim("done", job)
        claimed = self._update_job(
            job_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            or_(
                JobRecord.lease_owner.is_(None),
                JobRecord.lease_until.is_(None),
                JobRecord.lease_until < now,
                JobRecord.lease_owner == worker_id,
            ),
            state=names.RUNNING,
            stage=stage,
            lease_owner=worker_id,
            lease_until=now + lease_seconds,
            task_id=task_id,
            attempts=JobRecord.attempts + 1,
            started_at=func.coalesce(JobRecord.started_at, now),
            updated_at=now,
        )
        job = self.get_job(job_id)
        if claimed:
            return Claim("claimed", job)
        if job is None or job.state in names.TERMINAL_STATES:
            return Claim("gone", job)
        wait = max(0.0, (job.lease_until or now) - now)
        return Claim("busy", job, wait)

    def renew_lease(self, job_id: str, worker_id: str, lease_seconds: float) -> bool:
        """Extend a held lease; False when it is no longer ours or the job ended."""
        return self._update_job(
            job_id,
            JobRecord.lease_owner == worker_id,
            JobRecord.state == names.RUNNING,
            lease_until=time.time() + lease_seconds,
        )

    def set_progress(self, job_id: str, worker_id: str, progress: float) -> None:
        self._update_job(
            job_id,
            JobRecord.lease_owner == worker_id,
            progress=min(1.0, max(0.0, float(progress))),
            updated_at=time.time(),
        )

    def complete_stage(
        self,
        job_id: str,
        stage: str,
        worker_id: str,
        *,
        seconds: float,
        artifacts: dict[str, dict[str, Any]],
        handoff_lease_seconds: float,
    ) -> JobView | None:
        """Record a finished stage; the last stage makes the job ``succeeded``.

        Between stages the lease is released to nobody but kept alive for
        ``handoff_lease_seconds``, so a worker lost before the next stage
        starts is noticed.
        """
        now = time.time()
        with self.session() as s:
            r = s.get(JobRecord, job_id, with_for_update=True)
            if r is None or r.state in names.TERMINAL_STATES:
                return JobView.of(r) if r else None
            done = list(r.stages_done)
            if stage not in done:
                done.append(stage)
            r.stages_done = done
            r.stage_seconds = {**r.stage_seconds, stage: round(float(seconds), 4)}
            r.artifacts = {**r.artifacts, **artifacts}
            r.progress = len(done) / max(1, len(r.stages))
            r.updated_at = now
            if all(st in done for st in r.stages):
                for column, value in _ended(names.SUCCEEDED, now).items():
                    setattr(r, column, value)
                r.progress = 1.0
            else:
                r.lease_owner = None
                r.lease_until = now + handoff_lease_seconds
            return JobView.of(r)

    def fail_job(
        self, job_id: str, error: dict[str, Any], *, release_idempotency_key: bool = False
    ) -> None:
        """End an active job as failed with ``error`` ({type, message, field, stage}).

        ``release_idempotency_key``: also free the job's Idempotency-Key, so that
        the same key can create a new job (for a job that was never sent to a
        worker, e.g. when the broker refused it).
        """
        extra: dict[str, Any] = {"idempotency_key": None} if release_idempotency_key else {}
        self._update_job(
            job_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            error=error,
            **extra,
            **_ended(names.FAILED, time.time()),
        )

    def cancel_job(self, job_id: str, owner: str) -> JobView | None:
        """Cancel a queued or running job; returns the job after the change."""
        self._update_job(
            job_id,
            JobRecord.owner == owner,
            JobRecord.state.in_(names.ACTIVE_STATES),
            **_ended(names.CANCELLED, time.time()),
        )
        return self.get_job(job_id, owner)

    def delete_job(self, job_id: str, owner: str) -> bool:
        with self.session() as s:
            r = s.get(JobRecord, job_id)
            if r is None or r.owner != owner:
                return False
            s.delete(r)
            return True

    def expired_jobs(self, now: float | None = None, limit: int = 20) -> list[str]:
        """Ids of active jobs whose lease has run out."""
        now = time.time() if now is None else now
        with self.session() as s:
            return list(
                s.scalars(
                    select(JobRecord.id)
                    .where(
                        JobRecord.state.in_(names.ACTIVE_STATES),
                        JobRecord.lease_until.is_not(None),
                        JobRecord.lease_until < now,
                    )
                    .order_by(JobRecord.lease_until)
                    .limit(limit)
                )
            )

    def take_expired(self, job_id: str, grace_seconds: float) -> JobView | None:
        """Atomically take an expired job for requeueing (exactly one caller wins)."""
        now = time.time()
        taken = self._update_job(
            job_id,
            JobRecord.state.in_(names.ACTIVE_STATES),
            JobRecord.lease_until < now,
            lease_owner=None,
            lease_until=now + grace_seconds,
            requeues=JobRecord.requeues + 1,
            updated_at=now,
        )
        return self.get_job(job_id) if taken else None

    def jobs_by_ids(self, ids: Sequence[str]) -> list[JobView]:
        with self.session() as s:
            return [
                JobView.of(r) for r in s.scalars(select(JobRecord).where(JobRecord.id.in_(ids)))
            ]
