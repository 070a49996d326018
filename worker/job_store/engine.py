"""The job store's database connection, SQLite (WAL mode, a busy timeout) or
PostgreSQL, and the per-owner lock that makes the active-job limit atomic on both."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

from sqlalchemy import create_engine, event, text
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.orm import Session


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


def _owner_lock_key(owner: str) -> int:
    """A signed 64-bit key for PostgreSQL's advisory locks, fixed per owner."""
    digest = hashlib.sha256(b"conformorph-jobs:" + owner.encode()).digest()
    return int.from_bytes(digest[:8], "big", signed=True)


def lock_owner_jobs(s: Session, owner: str) -> None:
    """Make the transaction of ``s`` the only one that counts and adds ``owner``'s jobs
    until it ends, so that a count and the insert after it are one atomic step.

    Must come first in the transaction. SQLite: ``BEGIN IMMEDIATE`` takes the
    database's write lock before anything is read (other writers wait, up to the
    busy timeout), so the count sees every committed job and no job is added
    before this transaction ends. PostgreSQL: a transaction-scoped advisory lock
    on the owner (``pg_advisory_xact_lock``), released at commit or rollback; each
    statement after it reads what was committed before it (READ COMMITTED), so
    the count includes the jobs of the transaction that held the lock before.
    """
    conn = s.connection()
    dialect = conn.dialect.name
    if dialect == "sqlite":
        conn.exec_driver_sql("BEGIN IMMEDIATE")
    elif dialect == "postgresql":
        conn.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": _owner_lock_key(owner)})
    else:
        raise NotImplementedError(f"no per-owner job lock for the {dialect} database")
