"""``/v1/landmarks``: landmark documents, for ``POST /v1/morphs`` by ``landmarks_id``.

Any layout ``worker.landmarks_io`` reads is accepted, so the landmark files
shipped with the shared faces can be uploaded as they are: ``{"landmarks":
[[…], […]]}``, a shared list of vertex ids (ICT, MeshMonk), or ``face1`` /
``face2`` objects. The document is checked here (layout, counts) and resolved
against the meshes when a morph uses it.
"""

from __future__ import annotations

import json
from typing import Any

from fastapi import APIRouter, Body, Response
from fastapi.concurrency import run_in_threadpool

from service.api.deps import OwnerDep, StoreDep
from service.api.uploads import content_id, find_repeat, get_owned, upload_responses
from service.errors import ApiError
from service.schemas import ErrorBody, LandmarkSetPublic
from worker.landmarks_io import SHARED_LIST_KEYS, parse_landmark_json

router = APIRouter(prefix="/v1/landmarks", tags=["landmarks"])

ERRORS: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorBody, "description": "missing or unknown API key"},
    404: {"model": ErrorBody, "description": "no such landmark set for this key"},
    413: {"model": ErrorBody, "description": "document larger than the limit"},
    422: {"model": ErrorBody, "description": "not a landmark document"},
}


def landmark_lists(
    data: dict[str, Any], n_meshes: int | None
) -> tuple[list[list[Any]], int | None]:
    """Parse a landmark document for ``n_meshes`` meshes (None: as many as it holds).

    Returns (one list per mesh, the number of meshes the document itself fixes
    or None for a shared list); ApiError 422 naming the problem otherwise.
    """
    fixed: int | None
    if isinstance(data.get("landmarks"), list):
        fixed = len(data["landmarks"])
    elif any(k in data for k in SHARED_LIST_KEYS):
        fixed = None
    else:
        fixed = (
            sum(1 for k, v in data.items() if k.startswith("face") and isinstance(v, dict)) or None
        )
    n = n_meshes if n_meshes is not None else (fixed or 2)
    try:
        return parse_landmark_json(data, n), fixed
    except ValueError as exc:
        raise ApiError(422, getattr(exc, "code", "landmark_format"), str(exc), "landmarks") from exc


def _public(set_id: str, data: dict[str, Any], created_at: float) -> LandmarkSetPublic:
    lists, fixed = landmark_lists(data, None)
    return LandmarkSetPublic(
        id=set_id, meshes=fixed, landmarks_per_mesh=len(lists[0]), created_at=created_at
    )


@router.post(
    "",
    operation_id="upload_landmarks",
    status_code=201,
    responses=upload_responses(LandmarkSetPublic, ERRORS),
)
async def upload_landmarks(
    owner: OwnerDep,
    store: StoreDep,
    response: Response,
    document: dict[str, Any] = Body(  # noqa: B008 - FastAPI's way to take a free-form JSON object
        description='a landmark document, e.g. {"landmarks": [[ids of mesh 0], [ids of mesh 1]]}'
    ),
) -> LandmarkSetPublic:
    """Upload a landmark document (checked now, resolved on the meshes when a morph uses it)."""
    landmark_lists(document, None)
    blob = json.dumps(document, sort_keys=True, separators=(",", ":"))
    set_id = content_id(owner, blob, "landmarks")
    existing = await find_repeat(store.get_landmarks, owner, set_id, response)
    if existing is not None:
        return _public(set_id, *existing)
    created = await run_in_threadpool(store.add_landmarks, owner, set_id, document)
    return _public(set_id, document, created)


@router.get("/{set_id}", operation_id="get_landmarks", responses=ERRORS)
async def get_landmarks(set_id: str, owner: OwnerDep, store: StoreDep) -> LandmarkSetPublic:
    """An uploaded landmark set's summary (404 for other keys' sets)."""
    got = await get_owned(store.get_landmarks, owner, set_id, "landmark set", "set_id")
    return _public(set_id, *got)
