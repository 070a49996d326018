"""What every part of the job store stands on: the engine, sessions, and the few
statements the parts share (a view by owner and id, an insert-once, a conditional
job UPDATE, a count, a page)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, TypeVar

from sqlalchemy import ColumnElement, Select, func, select, text, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, sessionmaker

from conformorph.worker.job_store.engine import make_engine
from conformorph.worker.job_store.tables import Base, JobRecord
from conformorph.worker.job_store.views import view_of

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

_T = TypeVar("_T")
_V = TypeVar("_V", bound="DataclassInstance")


def count_rows(s: Session, model: type[Base], *where: ColumnElement[bool]) -> int:
    """``SELECT count(*) FROM model WHERE where``."""
    return int(s.scalar(select(func.count()).select_from(model).where(*where)) or 0)


def newest_first(stmt: Select[Any], model: Any, limit: int, offset: int) -> Select[Any]:
    """One page of ``stmt``, newest ``created_at`` first (ties by id)."""
    return stmt.order_by(model.created_at.desc(), model.id).limit(limit).offset(offset)


def present(value: _T | None) -> _T:
    """``value``, or RuntimeError when a row just written has vanished."""
    if value is None:
        raise RuntimeError("row vanished right after it was written")
    return value


class StoreBase:
    """The engine and sessions of a job store at ``url`` (tables created unless
    ``create`` is false)."""

    def __init__(self, url: str, *, create: bool = True) -> None:
        self.url = url
        self.engine = make_engine(url)
        self._sessions = sessionmaker(self.engine, expire_on_commit=False)
        if create:
            self.create_all()

    def create_all(self) -> None:
        Base.metadata.create_all(self.engine)
        if self.engine.dialect.name == "postgresql":
            # stores made before webhook secrets were encrypted (issue 30 item 11): a sealed
            # secret outgrows the old VARCHAR(512); idempotent
            with self.engine.begin() as c:
                c.execute(text("ALTER TABLE job_callbacks ALTER COLUMN secret TYPE TEXT"))

    def dispose(self) -> None:
        self.engine.dispose()

    @contextmanager
    def session(self) -> Iterator[Session]:
        with self._sessions() as s, s.begin():
            yield s

    def ping(self) -> bool:
        try:
            with self.engine.connect() as c:
                c.execute(text("SELECT 1"))
            return True
        except Exception:  # noqa: BLE001 - readiness probe reports any failure
            return False

    def _get_owned(
        self, record: type[Base], view: type[_V], owner: str, record_id: str
    ) -> _V | None:
        """The view of the ``(owner, id)`` row of an owner-scoped table, or None."""
        with self.session() as s:
            r = s.get(record, (owner, record_id))
            return view_of(view, r) if r else None

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
