"""Landmark uploads checked and stored in processes of their own, not the API's.

Reading a landmark document (``json.loads``), checking it and writing its
canonical text take time in proportion to its size, and the C parts of them
hold the interpreter lock throughout: in a thread of the API they still stop
its event loop (issue 30: 10 concurrent 3.3 MB documents held ``/healthz`` for
5.6 s). Here the raw body goes to a small pool of ``spawn``-ed processes, which
parse, check, store the document in the job store and answer a short summary.
The API's loop only copies the bytes.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from conformorph.service.errors import ApiError
from conformorph.service.landmark_checks import checked_landmarks_id, landmark_summary
from conformorph.worker.job_store import JobStore

#: processes checking landmark uploads (each holds one job store connection pool)
LANDMARK_PROCESSES = 2
#: seconds between a pool process's looks at whether the API that started it still lives
PARENT_CHECK_SECONDS = 1.0

_pool: ProcessPoolExecutor | None = None
_pool_lock = threading.Lock()
_stores: dict[str, JobStore] = {}


def landmark_pool() -> ProcessPoolExecutor:
    """The pool of this API process (created on first use)."""
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ProcessPoolExecutor(
                LANDMARK_PROCESSES,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=exit_with_parent,
                initargs=(os.getpid(),),
            )
        return _pool


def exit_with_parent(parent: int) -> None:
    """Pool initializer: end this process once ``parent`` (the API) is gone.

    A pool shut down by its API ends its processes; an API killed outright (SIGKILL, the
    out-of-memory killer) cannot, and its spawned processes, each holding the writing
    end of the pool's call queue, would wait on that queue for ever (two orphans per
    killed API, seen after test runs). A daemon thread looks every
    :data:`PARENT_CHECK_SECONDS` whether this process has been re-parented.
    """

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK_SECONDS)
        os._exit(0)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _store(database_url: str) -> JobStore:
    if database_url not in _stores:
        _stores[database_url] = JobStore(database_url)
    return _stores[database_url]


def _invalid(kind: str, msg: str, loc: list[Any], **extra: Any) -> dict[str, Any]:
    """What FastAPI's own body parsing reports (a :class:`RequestValidationError`'s errors)."""
    return {"invalid": [{"type": kind, "loc": loc, "msg": msg, "input": None, **extra}]}


def store_landmark_upload(database_url: str, owner: str, raw: bytes) -> dict[str, Any]:
    """Parse, check and store an uploaded landmark document (runs in a pool process).

    Parameters
    ----------
    database_url : str
        The job store.
    owner : str
        The uploading key's id.
    raw : bytes
        The request body.

    Returns
    -------
    dict
        ``{"public": {...}, "status": 201 | 200}`` (the set's summary; 200 when
        the same document was stored before), ``{"error": {"status", "type",
        "message", "field"}}`` for a document that is no landmark document, or
        ``{"invalid": [...]}`` for a body that is no JSON object (FastAPI's
        validation errors).
    """
    try:
        document = json.loads(raw)
    except json.JSONDecodeError as exc:
        return _invalid("json_invalid", "JSON decode error", ["body", exc.pos], ctx={})
    except (UnicodeDecodeError, RecursionError):
        return _invalid("json_invalid", "JSON decode error", ["body", 0], ctx={})
    if not isinstance(document, dict):
        return _invalid("dict_type", "Input should be a valid dictionary", ["body"])
    try:
        set_id = checked_landmarks_id(owner, document)
        store = _store(database_url)
        existing = store.get_landmarks(owner, set_id)
        if existing is not None:
            return {"public": landmark_summary(set_id, *existing).model_dump(), "status": 200}
        now = time.time()
        created = store.add_landmarks(owner, set_id, document, created_at=now)
        public = landmark_summary(set_id, document, created).model_dump()
    except ApiError as exc:
        return {
            "error": {
                "status": exc.status,
                "type": exc.type,
                "message": exc.message,
                "field": exc.field,
            }
        }
    # another request stored the same document first: one 201 only
    return {"public": public, "status": 201 if created == now else 200}
