"""Checks of a landmark document shared by the ``/v1/landmarks`` routes and the process
that checks uploads (:mod:`conformorph.service.landmark_process`): the layout and every
entry, non-finite numbers, the content id and the public summary."""

from __future__ import annotations

import json
import math
from typing import Any

from conformorph.pipelines.landmark_document import (
    Landmark,
    LandmarkError,
    document_mesh_count,
    parse_landmark_json,
)
from conformorph.service.api.uploads import content_id
from conformorph.service.errors import ApiError
from conformorph.service.schemas import LandmarkSetPublic


def landmark_lists(
    data: Any, n_meshes: int | None, *, stored: str | None = None
) -> tuple[list[list[Landmark]], int | None]:
    """Parse and check a landmark document for ``n_meshes`` meshes (None: as many as it holds).

    Returns (one checked list per mesh, the number of meshes the document itself
    fixes or None for a shared list); ApiError 422 naming the problem otherwise:
    its field is the place in the document (``landmarks[1][4]``), or
    ``landmarks_id`` for the stored document ``stored``.
    """
    try:
        fixed = document_mesh_count(data)
        n = n_meshes if n_meshes is not None else (fixed or 2)
        return parse_landmark_json(data, n), fixed
    except LandmarkError as exc:
        if stored is not None:
            raise ApiError(
                422, exc.code, f"landmark set {stored!r}: {exc}", "landmarks_id"
            ) from exc
        raise ApiError(422, exc.code, str(exc), exc.field or "landmarks") from exc


def _non_finite_at(document: Any) -> str | None:
    """Where a JSON value holds NaN or ±Infinity (which JSON itself has not), or None.

    Iterative: a deeply nested document cannot exhaust the stack here.
    """
    todo: list[tuple[Any, str]] = [(document, "")]
    while todo:
        x, where = todo.pop()
        if isinstance(x, float) and not math.isfinite(x):
            return where or "document"
        if isinstance(x, dict):
            todo += [(v, f"{where}.{k}" if where else str(k)) for k, v in reversed(x.items())]
        elif isinstance(x, list):
            todo += [(v, f"{where}[{i}]") for i, v in reversed(list(enumerate(x)))]
    return None


def landmark_summary(set_id: str, data: dict[str, Any], created_at: float) -> LandmarkSetPublic:
    lists, fixed = landmark_lists(data, None, stored=set_id)
    return LandmarkSetPublic(
        id=set_id, meshes=fixed, landmarks_per_mesh=len(lists[0]), created_at=created_at
    )


def checked_landmarks_id(owner: str, document: dict[str, Any]) -> str:
    """The id of a checked landmark document (ApiError 422 when it is not one)."""
    bad = _non_finite_at(document)
    if bad is not None:
        raise ApiError(422, "landmark_format", f"{bad}: NaN and Infinity are not JSON numbers", bad)
    landmark_lists(document, None)
    blob = json.dumps(document, sort_keys=True, separators=(",", ":"))
    return content_id(owner, blob, "landmarks")
