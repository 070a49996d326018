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
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from conformorph.pipelines.landmark_document import (
    SHARED_LIST_KEYS,
)
from conformorph.service.api.deps import OwnerDep, SettingsDep, StoreDep
from conformorph.service.api.uploads import get_owned, upload_responses
from conformorph.service.errors import ApiError
from conformorph.service.landmark_checks import landmark_summary
from conformorph.service.landmark_process import landmark_pool, store_landmark_upload
from conformorph.service.schemas import ErrorBody, LandmarkSetPublic, is_item_id

router = APIRouter(prefix="/v1/landmarks", tags=["landmarks"])

ERRORS: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorBody, "description": "missing or unknown API key"},
    404: {"model": ErrorBody, "description": "no such landmark set for this key"},
    413: {"model": ErrorBody, "description": "document larger than the limit"},
    422: {"model": ErrorBody, "description": "not a landmark document"},
}


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


@router.get("/{set_id}", operation_id="get_landmarks", responses=ERRORS)
async def get_landmarks(set_id: str, owner: OwnerDep, store: StoreDep) -> LandmarkSetPublic:
    """An uploaded landmark set's summary (404 for other keys' sets)."""
    got = await get_owned(store.get_landmarks, owner, set_id, "landmark set", "set_id")
    return await run_in_threadpool(landmark_summary, set_id, *got)


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
