"""``/v1/landmarks``: landmark documents, for ``POST /v1/morphs`` by ``landmarks_id``.

Any layout ``conformorph.pipelines.landmark_document`` reads is accepted, so the landmark files
shipped with the shared faces can be uploaded as they are: ``{"landmarks":
[[…], […]]}``, a shared list of vertex ids (ICT, MeshMonk), or ``face1`` /
``face2`` objects. The document is checked fully here (layout, counts, every
entry a vertex id ≥ 0 or a finite ``[x, y, z]``) and resolved against the
meshes when a morph uses it. Its size is limited by ``max_landmark_bytes``.
"""

from __future__ import annotations

import asyncio
import json
import math
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from conformorph.pipelines.landmark_document import (
    SHARED_LIST_KEYS,
    Landmark,
    LandmarkError,
    document_mesh_count,
    parse_landmark_json,
)
from conformorph.service.api.deps import OwnerDep, SettingsDep, StoreDep
from conformorph.service.api.uploads import content_id, get_owned, upload_responses
from conformorph.service.errors import ApiError
from conformorph.service.landmark_process import landmark_pool, store_landmark_upload
from conformorph.service.schemas import ErrorBody, LandmarkSetPublic, is_item_id

router = APIRouter(prefix="/v1/landmarks", tags=["landmarks"])

ERRORS: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorBody, "description": "missing or unknown API key"},
    404: {"model": ErrorBody, "description": "no such landmark set for this key"},
    413: {"model": ErrorBody, "description": "document larger than the limit"},
    422: {"model": ErrorBody, "description": "not a landmark document"},
}


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


#: what :func:`conformorph.pipelines.landmark_document.document_mesh_count` accepts: a
#: "landmarks" list of lists, a shared-data layout's key, or face1/face2/… objects
DOCUMENT_SCHEMA: dict[str, Any] = {
    "anyOf": [
        {
            "required": ["landmarks"],
            "properties": {"landmarks": {"type": "array", "items": {"type": "array"}}},
        },
        *({"required": [k]} for k in SHARED_LIST_KEYS),
        {"not": {"propertyNames": {"not": {"pattern": "^face"}}}, "minProperties": 1},
    ]
}


def _public(set_id: str, data: dict[str, Any], created_at: float) -> LandmarkSetPublic:
    lists, fixed = landmark_lists(data, None, stored=set_id)
    return LandmarkSetPublic(
        id=set_id, meshes=fixed, landmarks_per_mesh=len(lists[0]), created_at=created_at
    )


#: the request body as OpenAPI describes it (the route reads the raw bytes itself)
UPLOAD_BODY: dict[str, Any] = {
    "requestBody": {
        "content": {
            "application/json": {
                "schema": {
                    "additionalProperties": True,
                    **DOCUMENT_SCHEMA,
                    "description": 'a landmark document, e.g. {"landmarks": [[ids of mesh 0], '
                    "[ids of mesh 1]]}",
                    "title": "Document",
                    "type": "object",
                }
            }
        },
        "required": True,
    }
}


@router.post(
    "",
    operation_id="upload_landmarks",
    status_code=201,
    responses=upload_responses(LandmarkSetPublic, ERRORS),
    openapi_extra=UPLOAD_BODY,
)
async def upload_landmarks(
    request: Request, owner: OwnerDep, settings: SettingsDep, response: Response
) -> LandmarkSetPublic:
    """Upload a landmark document (checked now, resolved on the meshes when a morph uses it)."""
    raw = await request.body()
    ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if not raw:
        raise RequestValidationError(
            [{"type": "missing", "loc": ("body",), "msg": "Field required", "input": None}]
        )
    if ctype != "application/json" and not ctype.endswith("+json"):
        raise RequestValidationError(
            [{"type": "dict_type", "loc": ("body",), "msg": "Input should be a valid dictionary"}]
        )
    # parsed, checked and stored in a process of its own: nothing in proportion to the
    # document runs in this one, whose event loop serves every other request
    # (issue 30: 10 concurrent 3.3 MB documents held /healthz for 5.6 s)
    out = await asyncio.get_running_loop().run_in_executor(
        landmark_pool(), store_landmark_upload, settings.resolved_database_url, owner, raw
    )
    if "invalid" in out:
        raise RequestValidationError(out["invalid"])
    if "error" in out:
        e = out["error"]
        raise ApiError(e["status"], e["type"], e["message"], e["field"])
    response.status_code = out["status"]
    return LandmarkSetPublic(**out["public"])


def _checked_id(owner: str, document: dict[str, Any]) -> str:
    """The id of a checked landmark document (ApiError 422 when it is not one)."""
    bad = _non_finite_at(document)
    if bad is not None:
        raise ApiError(422, "landmark_format", f"{bad}: NaN and Infinity are not JSON numbers", bad)
    landmark_lists(document, None)
    blob = json.dumps(document, sort_keys=True, separators=(",", ":"))
    return content_id(owner, blob, "landmarks")


@router.get("/{set_id}", operation_id="get_landmarks", responses=ERRORS)
async def get_landmarks(set_id: str, owner: OwnerDep, store: StoreDep) -> LandmarkSetPublic:
    """An uploaded landmark set's summary (404 for other keys' sets)."""
    got = await get_owned(store.get_landmarks, owner, set_id, "landmark set", "set_id")
    return await run_in_threadpool(_public, set_id, *got)


@router.get(
    "/{set_id}/document",
    operation_id="get_landmark_document",
    responses={
        **ERRORS,
        200: {
            "description": "Successful Response",
            "content": {
                "application/json": {
                    "schema": {
                        "type": "object",
                        "additionalProperties": True,
                        "title": "Response Get Landmark Document",
                    }
                }
            },
        },
    },
    response_class=JSONResponse,
)
async def get_landmark_document(set_id: str, owner: OwnerDep, store: StoreDep) -> Response:
    """The stored landmark document itself, as uploaded or as a detection job stored it (with
    confidences and warnings): to edit and upload again."""
    # the stored JSON text as it is: nothing parsed or serialised, on the event loop or
    # off it (issue 30: 20 concurrent GETs of a 150k-point document held /healthz 12.8 s)
    if not is_item_id(set_id):
        raise ApiError(404, "not_found", f"no landmark set {set_id!r}", "set_id")
    loop = asyncio.get_running_loop()
    text = await loop.run_in_executor(_DOCUMENTS, store.get_landmarks_json, owner, set_id)
    if text is None:
        raise ApiError(404, "not_found", f"no landmark set {set_id!r}", "set_id")
    return Response(content=text.encode(), media_type="application/json")


#: threads reading whole landmark documents: few, so that however many such requests
#: arrive, the event loop still gets the interpreter often (each read holds it while
#: it builds a multi-megabyte string)
_DOCUMENTS = ThreadPoolExecutor(2, "conformorph-documents")
