"""Which uploads a job's parameters use (for retention and for the check that a job's
inputs still exist when it is created).

A job's parameters name an uploaded file as ``{"id": …, "storage_key": …, …}``
(meshes, shapes, textures) and may carry other uploads' ids as plain strings
(``landmarks_id``). Both are found by walking the parameters.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from conformorph.worker.job_store.tables import MeshRecord, ShapeRecord, TextureRecord

#: the tables of uploaded files (each row has owner, id, storage_key, size_bytes)
FILE_TABLES: tuple[type[MeshRecord] | type[ShapeRecord] | type[TextureRecord], ...] = (
    MeshRecord,
    ShapeRecord,
    TextureRecord,
)


def _walk(value: Any) -> Iterator[Any]:
    yield value
    if isinstance(value, dict):
        for v in value.values():
            yield from _walk(v)
    elif isinstance(value, list):
        for v in value:
            yield from _walk(v)


def file_refs(params: dict[str, Any]) -> set[tuple[str, str]]:
    """``(id, storage_key)`` of every uploaded file the parameters name."""
    return {
        (str(v["id"]), str(v["storage_key"]))
        for v in _walk(params)
        if isinstance(v, dict) and "storage_key" in v and "id" in v
    }


def used_ids(params: dict[str, Any]) -> set[str]:
    """Every string in the parameters (upload ids among them) and every file id."""
    out = {v for v in _walk(params) if isinstance(v, str)}
    out.update(i for i, _ in file_refs(params))
    return out


def missing_inputs(s: Session, owner: str, params: dict[str, Any]) -> list[str]:
    """Ids of the files the parameters name that no longer exist for ``owner`` (deleted
    by the retention cleanup since the route looked them up)."""
    missing = []
    for item_id, key in sorted(file_refs(params)):
        found = any(
            s.scalar(
                select(table.id).where(
                    table.owner == owner, table.id == item_id, table.storage_key == key
                )
            )
            is not None
            for table in FILE_TABLES
        )
        if not found:
            missing.append(item_id)
    return missing
