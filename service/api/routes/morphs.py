"""``POST /v1/morphs`` (faces, conformal morphing) and ``POST /v1/morphs2d`` (2D strain-field)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from fastapi import APIRouter
from fastapi.concurrency import run_in_threadpool

from conformorph.pipelines.job_fields import FieldRangeError, check_morph_times
from conformorph.pipelines.landmark_document import landmark_fill, landmark_indices
from conformorph.service.api.submit import (
    JOB_RESPONSES,
    SubmissionDep,
    check_frame_limit,
    check_repairs,
    mesh_param,
    missing_input,
    require_mesh,
)
from conformorph.service.errors import ApiError
from conformorph.service.landmark_checks import landmark_lists
from conformorph.service.schemas import JobPublic, Morph2dCreate, MorphCreate
from conformorph.worker import names
from conformorph.worker.job_store import JobStore

router = APIRouter(tags=["morphs"])


def _texture_param(store: JobStore, owner: str, tex_id: str, field: str) -> dict[str, Any]:
    t = store.get_texture(owner, tex_id)
    if t is None:
        raise missing_input(store, owner, tex_id, "texture", field)
    return {"id": t.id, "storage_key": t.storage_key, "content_type": t.content_type}


def check_times(body: MorphCreate) -> None:
    """``times`` and ``frame_times`` against the ranges every entry point shares
    (:mod:`conformorph.pipelines.job_fields`); ApiError 422 ``out_of_range`` naming the entry."""
    try:
        check_morph_times(body.times, body.frame_times, len(body.meshes))
    except FieldRangeError as exc:
        raise ApiError(422, exc.code, str(exc), exc.field) from exc


@router.post("/v1/morphs", operation_id="create_morph", status_code=202, responses=JOB_RESPONSES)
async def create_morph(body: MorphCreate, job: SubmissionDep) -> JobPublic:
    """Morph two or more faces with landmarks: ``animation.glb`` (one morph target per frame),
    optional ``frames/NNN.glb``, ``metrics.json``. Stages: prepare, register, frames, export,
    metrics; with ``"landmarks": "auto"`` detect_landmarks first (``landmarks.json``)."""
    store, owner = job.store, job.owner
    n = len(body.meshes)
    if n > job.settings.max_key_frames:
        raise ApiError(
            422,
            "too_many_key_frames",
            f"{n} meshes; the limit is {job.settings.max_key_frames}",
            "meshes",
        )
    if body.frame_times is not None:
        if "frames" in body.model_fields_set:
            raise ApiError(
                422, "validation_error", "give frames or frame_times, not both", "frame_times"
            )
        check_frame_limit(len(body.frame_times), job.settings)
    else:
        check_frame_limit(body.frames, job.settings)
    check_times(body)
    if (body.landmarks is None) == (body.landmarks_id is None):
        raise ApiError(
            422, "validation_error", "give exactly one of landmarks and landmarks_id", "landmarks"
        )
    # inline or stored, the landmarks pass the same checks (conformorph.pipelines.landmark_document)
    landmarks: Any
    fill: dict[str, Any] = {}
    if body.landmarks_id is not None:
        got = await run_in_threadpool(store.get_landmarks, owner, body.landmarks_id)
        if got is None:
            raise await run_in_threadpool(
                missing_input, store, owner, body.landmarks_id, "landmark set", "landmarks_id"
            )
        landmarks, _ = landmark_lists(got[0], n, stored=body.landmarks_id)
        fill = _fill_params(got[0], len(landmarks[0]))
    elif body.landmarks == names.AUTO_LANDMARKS:
        landmarks = names.AUTO_LANDMARKS  # the detect_landmarks stage finds them
    else:
        landmarks, _ = landmark_lists({"landmarks": body.landmarks}, n)
    provenance = _checked_provenance(body.landmark_provenance, landmarks)
    meshes = []
    granted = body.repairs()
    views = []
    for i, mid in enumerate(body.meshes):
        m = await run_in_threadpool(require_mesh, store, owner, mid, f"meshes[{i}]")
        check_repairs(m, f"meshes[{i}]", granted)
        meshes.append(mesh_param(m))
        views.append(m)
    textures = None
    if body.textures:
        if len(body.textures) != n:
            raise ApiError(
                422, "validation_error", f"textures needs one id per mesh ({n})", "textures"
            )
        textures = [
            _texture_param(store, owner, t, f"textures[{i}]") for i, t in enumerate(body.textures)
        ]
        for i, m in enumerate(views):
            # the upload report knows (meshes stored before it was recorded lack the key)
            if m.report.get("texture_coordinates") is False:
                raise ApiError(
                    422,
                    "mesh_without_texture_coordinates",
                    f"textures[{i}] needs texture coordinates on meshes[{i}] (one per vertex), "
                    f"and mesh {m.id!r} has none: upload it with its UVs (OBJ vt lines, PLY s "
                    "and t, glTF TEXCOORD_0) or leave textures out",
                    f"textures[{i}]",
                )
    params = {
        "meshes": meshes,
        "times": body.times,
        "landmarks": landmarks,
        "frames": body.frames,
        "frame_times": body.frame_times,
        "method": body.method,
        "refine": body.refine,
        "landmark_fit": body.landmark_fit,
        "curvature": body.curvature,
        "consistent": body.consistent,
        "textures": textures,
        "per_frame": body.per_frame,
        "normals": body.normals,
        "baselines": body.baselines,
        "units": body.units,
        "compress": body.compress,
        "output_resolution": body.output_resolution,
        "fill_holes": body.fill_holes,
        "remove_ears": body.remove_ears,
        "prepare": body.prepare,
        "vertex_budget": body.vertex_budget,
    }
    if provenance is not None:
        params["landmark_provenance"] = provenance
    params.update(fill)
    return await job.submit(names.KIND_MORPH, params, body)


def _fill_params(document: Any, count: int) -> dict[str, Any]:
    """The job parameters of a stored landmark set asking for ``"fill": "auto"`` (its given
    points' ibug ``"indices"``; the worker detects the rest first), or none.

    The document was checked by ``landmark_lists``."""
    if landmark_fill(document) is None:
        return {}
    return {
        names.LANDMARK_FILL: landmark_fill(document),
        "landmark_indices": landmark_indices(document, count),
    }


def _checked_provenance(
    provenance: Sequence[Sequence[str]] | None, landmarks: Any
) -> list[list[str]] | None:
    """``landmark_provenance`` when it matches the landmarks list for list (422 otherwise)."""
    if provenance is None:
        return None
    if landmarks == names.AUTO_LANDMARKS:
        raise ApiError(
            422, "validation_error",
            "landmark_provenance describes given landmarks; with \"landmarks\": \"auto\" the "
            "job's metrics say they were detected", "landmark_provenance",
        )  # fmt: skip
    if len(provenance) != len(landmarks):
        raise ApiError(
            422, "validation_error",
            f"landmark_provenance needs one list per mesh ({len(landmarks)}), got "
            f"{len(provenance)}", "landmark_provenance",
        )  # fmt: skip
    for i, (p, lm) in enumerate(zip(provenance, landmarks, strict=True)):
        if len(p) != len(lm):
            raise ApiError(
                422, "validation_error",
                f"landmark_provenance[{i}] has {len(p)} entries but mesh {i + 1} has "
                f"{len(lm)} landmarks", f"landmark_provenance[{i}]",
            )  # fmt: skip
    return [list(p) for p in provenance]


#: Two anchors of one shape closer than this fraction of its bounding-box diagonal
#: are one point: the worker's conformorph.geometry.tolerances.ANCHOR_COINCIDENT_RTOL (not
#: imported: the API loads no geometry; a test keeps the two equal).
ANCHOR_COINCIDENT_RTOL = 1e-6
#: Slack of the bounding-box test, as the worker's point-in-shape test allows
#: (points within 1e-9 of the diagonal of the boundary count as inside).
_INSIDE_RTOL = 1e-9


def check_morph2d_inputs(
    source: dict[str, Any], target: dict[str, Any], anchors: list[list[list[float]]]
) -> None:
    """What can be checked from the stored shape reports before a 2D morph is enqueued.

    Every anchor inside its shape's bounding box (the exact point-in-shape test needs the rings, which only
    the worker reads); no two anchors at one point of a shape. Reports of
    shapes stored before ``bbox`` was recorded skip the anchor checks.
    """
    for side, name, report in ((0, "source", source), (1, "target", target)):
        bbox = report.get("bbox")
        if not (isinstance(bbox, list) and len(bbox) == 4):
            continue
        x0, y0, x1, y1 = (float(v) for v in bbox)
        diag = math.hypot(x1 - x0, y1 - y0)
        slack = _INSIDE_RTOL * diag
        pts = [(float(pair[side][0]), float(pair[side][1])) for pair in anchors]
        for i, (x, y) in enumerate(pts):
            if not (x0 - slack <= x <= x1 + slack and y0 - slack <= y <= y1 + slack):
                raise ApiError(
                    422,
                    "anchor_outside_shape",
                    f"anchor {i} {[x, y]} lies outside the {name} shape "
                    f"(outside its bounding box {[x0, y0, x1, y1]})",
                    f"anchors[{i}][{side}]",
                )
        tol = ANCHOR_COINCIDENT_RTOL * diag
        order = sorted(range(len(pts)), key=lambda k: pts[k][0])
        for a, i in enumerate(order):
            for j in order[a + 1 :]:
                if pts[j][0] - pts[i][0] > tol:
                    break
                if math.dist(pts[i], pts[j]) <= tol:
                    lo, hi = sorted((i, j))
                    raise ApiError(
                        422,
                        "duplicate_anchors",
                        f"anchors {lo} and {hi} are the same {name} point {list(pts[lo])}: "
                        "each anchor must be a distinct point of both shapes",
                        f"anchors[{hi}][{side}]",
                    )


@router.post(
    "/v1/morphs2d", operation_id="create_morph2d", status_code=202, responses=JOB_RESPONSES
)
async def create_morph2d(body: Morph2dCreate, job: SubmissionDep) -> JobPublic:
    """Morph one 2D shape into another by strain-field interpolation: ``animation.glb``,
    optional ``frames/NNN.glb``, ``strip.svg``, ``animation.svg``, ``animation.json``
    (Lottie), ``frames.json``, ``metrics.json`` (and ``anchors.json`` when the anchors are
    found automatically)."""
    store, owner = job.store, job.owner
    check_frame_limit(body.frames, job.settings)
    anchors = body.anchors or []
    if body.point_budget is not None and 0 < body.point_budget < 3:
        raise ApiError(
            422, "bad_point_budget", "point_budget must be 0 or at least 3", "point_budget"
        )
    for i, pair in enumerate(anchors):
        if len(pair) != 2 or any(len(p) != 2 or not all(math.isfinite(x) for x in p) for p in pair):
            raise ApiError(
                422, "anchor_format", f"anchor {i} must be [[xs, ys], [xt, yt]]", f"anchors[{i}]"
            )
    for k, path in enumerate(body.paths or []):
        bad = [x for x in path if not 0 <= x < len(anchors)]
        if len(path) < 2 or bad:
            raise ApiError(
                422,
                "bad_path",
                f"path {k} must list at least two anchor indices in 0..{len(anchors) - 1}"
                + (f"; {bad[0]} is not one" if bad else ""),
                f"paths[{k}]",
            )
    shapes, reports = {}, {}
    for field in ("source", "target"):
        sid = getattr(body, field)
        sh = await run_in_threadpool(store.get_shape, owner, sid)
        if sh is None:
            raise await run_in_threadpool(missing_input, store, owner, sid, "shape", field)
        shapes[field] = {"id": sh.id, "storage_key": sh.storage_key, "file_type": sh.file_type}
        reports[field] = sh.report
    check_morph2d_inputs(reports["source"], reports["target"], anchors)
    texture = (
        await run_in_threadpool(_texture_param, store, owner, body.texture, "texture")
        if body.texture
        else None
    )
    if texture is not None and texture["content_type"] != "image/png":
        raise ApiError(422, "unsupported_image", "the 2D morph's texture must be a PNG", "texture")
    params: dict[str, Any] = {
        **shapes,
        "anchors": body.anchors,
        "paths": body.paths or [],
        "frames": body.frames,
        "interp": body.interp,
        "pace": body.pace,
        "loop": body.loop,
        "per_frame": body.per_frame,
        "texture": texture,
        "max_points": job.settings.max_shape_points,
    }
    if body.point_budget is not None:
        params["point_budget"] = body.point_budget
    if body.units != "px":  # only what differs from the default: earlier jobs' params stand
        params["units"] = body.units
    if body.size is not None:
        params["size"] = body.size
    return await job.submit(names.KIND_MORPH2D, params, body)
