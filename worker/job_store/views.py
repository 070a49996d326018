"""Detached, read-only copies of the job store's rows (what the store hands out:
no session, no lazy loading, nothing shared with the database layer)."""

from __future__ import annotations

import copy
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

    from conformorph.worker.job_store.tables import (
        JobRecord,
        MeshRecord,
        ShapeRecord,
        TextureRecord,
    )

_V = TypeVar("_V", bound="DataclassInstance")


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
        return view_of(cls, r)

    @property
    def remaining_stages(self) -> list[str]:
        return [s for s in self.stages if s not in self.stages_done]


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
        return view_of(cls, r)


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
        return view_of(cls, r)


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


def view_of(cls: type[_V], row: Any) -> _V:
    """A detached copy of a row (ORM object or Core row) as the view dataclass ``cls``:
    every field of ``cls`` read from the row's attribute of the same name, JSON
    values (lists, dicts) copied so the view shares nothing with the session."""
    return cls(**{f.name: copy.deepcopy(getattr(row, f.name)) for f in fields(cls)})
