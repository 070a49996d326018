"""Every endpoint once, as a description of the request and how to read its answer.

Each function here takes a client method's parameters and returns the
:class:`Call` to send: method, path, body, headers, the statuses that mean
success and the parser of the answer. Both clients make their methods from these
functions (:class:`~conformorph_client._endpoint.Endpoint`), so a docstring here
is the docstring of ``Client.<name>`` and ``AsyncClient.<name>``, and the two
clients cannot drift. The flows around a call (sending, streams, downloads,
waiting) are in :mod:`conformorph_client._flows`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar
from urllib.parse import quote

import httpx
from pydantic import BaseModel

from conformorph_client._job_fields import check_morph_times
from conformorph_client.errors import error_from_response
from conformorph_client.models import (
    ArtifactLink,
    Health,
    JobList,
    JobPublic,
    LandmarkSetPublic,
    MeshPublic,
    Readiness,
    ShapePublic,
    TexturePublic,
)

T = TypeVar("T")
M = TypeVar("M", bound=BaseModel)

#: an upload: a path, or (file name, bytes)
UploadSource = str | Path | tuple[str, bytes]


@dataclass(frozen=True)
class Call(Generic[T]):
    """One request and the parser of its successful answer."""

    method: str
    path: str
    parse: Callable[[httpx.Response], T]
    ok: tuple[int, ...] = (200,)
    params: dict[str, Any] | None = None
    json: Any = None
    headers: dict[str, str] = field(default_factory=dict)
    upload: UploadSource | None = None

    @property
    def repeatable(self) -> bool:
        """Whether sending this call twice has the effect of sending it once: reads and
        deletes, content-addressed uploads (the same bytes give the same id, 200 on a
        repeat) and job submissions that carry an ``Idempotency-Key``."""
        return (
            self.method in ("GET", "HEAD", "DELETE")
            or self.upload is not None
            or self.path == "/v1/landmarks"
            or "Idempotency-Key" in self.headers
        )

    def check(self, response: httpx.Response) -> T:
        """Parse a read response, raising the typed error for an error status."""
        if response.status_code not in self.ok:
            raise error_from_response(response)
        return self.parse(response)


def _json(r: httpx.Response) -> dict[str, Any]:
    out: dict[str, Any] = r.json()
    return out


def _model(model: type[M]) -> Callable[[httpx.Response], M]:
    return lambda r: model.model_validate_json(r.content)


def _job_or_none(r: httpx.Response) -> JobPublic | None:
    return None if r.status_code == 204 else JobPublic.model_validate_json(r.content)


def _seg(value: str) -> str:
    """An id as one URL path segment (so ``../x`` cannot change the route)."""
    if not value:
        raise ValueError("an id must not be empty")
    return quote(value, safe="")


def _drop_none(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if v is not None}


def _listed(items: Sequence[Any] | None) -> list[Any] | None:
    return list(items) if items is not None else None


def _upload(path: str, model: type[M], source: UploadSource) -> Call[M]:
    """``POST`` of a file: 201 with a new record, 200 with the one the same bytes made."""
    return Call("POST", path, _model(model), ok=(200, 201), upload=source)


def _submission(path: str, body: dict[str, Any], idempotency_key: str | None) -> Call[JobPublic]:
    """``POST`` of a job: 202 with the new job, 200 with the one this
    ``Idempotency-Key`` already made (sent only when given)."""
    headers = {"Idempotency-Key": idempotency_key} if idempotency_key is not None else {}
    return Call("POST", path, _model(JobPublic), ok=(200, 202), json=body, headers=headers)


# --------------------------------------------------------------------------- health


def healthz() -> Call[Health]:
    """``GET /healthz``."""
    return Call("GET", "/healthz", _model(Health))


def readyz() -> Call[Readiness]:
    """``GET /readyz`` (a 503 answer is returned too: see ``status`` and ``checks``)."""
    return Call("GET", "/readyz", _model(Readiness), ok=(200, 503))


# --------------------------------------------------------------------------- inputs


def upload_mesh(source: UploadSource) -> Call[MeshPublic]:
    """Upload a mesh file (path, or ``(name, bytes)``); the same bytes give the same id."""
    return _upload("/v1/meshes", MeshPublic, source)


def get_mesh(mesh_id: str) -> Call[MeshPublic]:
    """``GET /v1/meshes/{mesh_id}``: an uploaded mesh's record."""
    return Call("GET", f"/v1/meshes/{_seg(mesh_id)}", _model(MeshPublic))


def upload_texture(source: UploadSource) -> Call[TexturePublic]:
    """Upload a PNG or JPEG texture (path, or ``(name, bytes)``)."""
    return _upload("/v1/textures", TexturePublic, source)


def get_texture(texture_id: str) -> Call[TexturePublic]:
    """``GET /v1/textures/{texture_id}``: an uploaded texture's record."""
    return Call("GET", f"/v1/textures/{_seg(texture_id)}", _model(TexturePublic))


def upload_shape(source: UploadSource) -> Call[ShapePublic]:
    """Upload a 2D shape (JSON rings or SVG) for 2D morphs."""
    return _upload("/v1/shapes", ShapePublic, source)


def get_shape(shape_id: str) -> Call[ShapePublic]:
    """``GET /v1/shapes/{shape_id}``: an uploaded shape's record."""
    return Call("GET", f"/v1/shapes/{_seg(shape_id)}", _model(ShapePublic))


def upload_landmarks(document: dict[str, Any]) -> Call[LandmarkSetPublic]:
    """Upload a landmark document (any layout the server reads); use its id as
    ``landmarks_id`` in a morph."""
    return Call("POST", "/v1/landmarks", _model(LandmarkSetPublic), ok=(200, 201), json=document)


def get_landmarks(set_id: str) -> Call[LandmarkSetPublic]:
    """``GET /v1/landmarks/{set_id}``: an uploaded landmark set."""
    return Call("GET", f"/v1/landmarks/{_seg(set_id)}", _model(LandmarkSetPublic))


def get_landmark_document(set_id: str) -> Call[dict[str, Any]]:
    """``GET /v1/landmarks/{set_id}/document``: the stored document itself (to edit and upload
    again), detected ones with their confidences and warnings."""
    return Call("GET", f"/v1/landmarks/{_seg(set_id)}/document", _json)


# --------------------------------------------------------------------------- jobs


def _callback(url: str | None, secret: str | None) -> dict[str, str | None]:
    """The webhook fields of a job-creating request (``None`` values are dropped)."""
    return {"callback_url": url, "callback_secret": secret}


def detect_landmarks(
    meshes: Sequence[str],
    *,
    min_score: float | None = None,
    idempotency_key: str | None = None,
    callback_url: str | None = None,
    callback_secret: str | None = None,
) -> Call[JobPublic]:
    """``POST /v1/landmark-detections``: start a job detecting the 68 Multi-PIE landmarks on
    uploaded face meshes; its ``landmarks.json`` holds the document and its ``landmarks_id``."""
    body = _drop_none(
        {"meshes": list(meshes), "min_score": min_score, **_callback(callback_url, callback_secret)}
    )
    return _submission("/v1/landmark-detections", body, idempotency_key)


def create_conformal_map(
    mesh: str,
    *,
    method: str = "fast",
    center_vertex: int | None = None,
    angle_vertex: int | None = None,
    idempotency_key: str | None = None,
    refine_angles: bool | None = None,
    fill_holes: bool | None = None,
    remove_ears: bool | None = None,
    prepare: str | None = None,
    vertex_budget: int | None = None,
    callback_url: str | None = None,
    callback_secret: str | None = None,
) -> Call[JobPublic]:
    """``POST /v1/conformal-maps``: start a disk-map job."""
    body = {
        "mesh": mesh,
        "method": method,
        "center_vertex": center_vertex,
        "angle_vertex": angle_vertex,
        "refine_angles": refine_angles,
        "fill_holes": fill_holes,
        "remove_ears": remove_ears,
        "prepare": prepare,
        "vertex_budget": vertex_budget,
        **_callback(callback_url, callback_secret),
    }
    return _submission("/v1/conformal-maps", _drop_none(body), idempotency_key)


def create_reconstruction(
    mesh: str,
    *,
    method: str = "fast",
    curvature: str = "vector",
    idempotency_key: str | None = None,
    fill_holes: bool | None = None,
    remove_ears: bool | None = None,
    fold_correction: bool | None = None,
    prepare: str | None = None,
    vertex_budget: int | None = None,
    callback_url: str | None = None,
    callback_secret: str | None = None,
) -> Call[JobPublic]:
    """``POST /v1/reconstructions``: start a map + (H, λ) + reconstruction job."""
    body = {
        "mesh": mesh,
        "method": method,
        "curvature": curvature,
        "fill_holes": fill_holes,
        "remove_ears": remove_ears,
        "fold_correction": fold_correction,
        "prepare": prepare,
        "vertex_budget": vertex_budget,
        **_callback(callback_url, callback_secret),
    }
    return _submission("/v1/reconstructions", _drop_none(body), idempotency_key)


def create_morph(
    meshes: Sequence[str],
    *,
    landmarks: Sequence[Sequence[Any]] | str | None = None,
    landmarks_id: str | None = None,
    times: Sequence[float] | None = None,
    frames: int | None = None,
    method: str | None = None,
    curvature: str | None = None,
    consistent: str | None = None,
    textures: Sequence[str] | None = None,
    per_frame: bool | None = None,
    normals: bool | None = None,
    extra: dict[str, Any] | None = None,
    idempotency_key: str | None = None,
    frame_times: Sequence[float] | None = None,
    refine: str | None = None,
    fill_holes: bool | None = None,
    remove_ears: bool | None = None,
    landmark_fit: str | None = None,
    prepare: str | None = None,
    vertex_budget: int | None = None,
    callback_url: str | None = None,
    callback_secret: str | None = None,
    units: str | None = None,
    compress: str | None = None,
    output_resolution: str | None = None,
    baselines: bool | None = None,
) -> Call[JobPublic]:
    """``POST /v1/morphs``: start a face-morph job over uploaded meshes; parameters
    left ``None`` take the server's defaults, ``extra`` adds body fields as given.
    ``landmarks="auto"`` detects them on the worker first (the job's ``landmarks.json``).

    ``times`` and ``frame_times`` are checked here against the ranges the server checks
    (``ValueError`` naming the entry, before anything is sent)."""
    check_morph_times(_listed(times), _listed(frame_times), len(meshes))
    if isinstance(landmarks, str):
        listed: Any = landmarks
    else:
        listed = [list(x) for x in landmarks] if landmarks is not None else None
    body = _drop_none(
        {
            "meshes": list(meshes),
            "landmarks": listed,
            "landmarks_id": landmarks_id,
            "times": _listed(times),
            "frames": frames,
            "frame_times": _listed(frame_times),
            "method": method,
            "refine": refine,
            "curvature": curvature,
            "consistent": consistent,
            "textures": _listed(textures),
            "per_frame": per_frame,
            "normals": normals,
            "fill_holes": fill_holes,
            "remove_ears": remove_ears,
            "landmark_fit": landmark_fit,
            "prepare": prepare,
            "vertex_budget": vertex_budget,
            "units": units,
            "compress": compress,
            "output_resolution": output_resolution,
            "baselines": baselines,
            **_callback(callback_url, callback_secret),
        }
    )
    body.update(extra or {})
    return _submission("/v1/morphs", body, idempotency_key)


def create_morph2d(
    source: str,
    target: str,
    *,
    anchors: Sequence[Sequence[Sequence[float]]] | None = None,
    frames: int | None = None,
    interp: str | None = None,
    per_frame: bool | None = None,
    texture: str | None = None,
    idempotency_key: str | None = None,
    pace: str | None = None,
    point_budget: int | None = None,
    loop: str | None = None,
    callback_url: str | None = None,
    callback_secret: str | None = None,
    units: str | None = None,
    size: float | None = None,
) -> Call[JobPublic]:
    """``POST /v1/morphs2d``: start a 2D strain-field morph between two uploaded shapes.

    Without ``anchors`` (or with fewer than 2 pairs, which seed the matching) the
    corresponding points are found automatically (the job's ``anchors.json``)."""
    body = {
        "source": source,
        "target": target,
        "anchors": None if anchors is None else [[list(p) for p in pair] for pair in anchors],
        "point_budget": point_budget,
        "frames": frames,
        "interp": interp,
        "per_frame": per_frame,
        "texture": texture,
        "pace": pace,
        "units": units,
        "size": size,
        "loop": loop,
        **_callback(callback_url, callback_secret),
    }
    return _submission("/v1/morphs2d", _drop_none(body), idempotency_key)


def get_job(job_id: str) -> Call[JobPublic]:
    """``GET /v1/jobs/{job_id}``: the job's state, progress, error and artifacts."""
    return Call("GET", f"/v1/jobs/{_seg(job_id)}", _model(JobPublic))


def get_job_params(job_id: str) -> Call[dict[str, Any]]:
    """``GET /v1/jobs/{job_id}/params``: every parameter whole (the job record shows values
    over 4 KB by reference, ``{"ref": …, "entries": n}``)."""
    return Call("GET", f"/v1/jobs/{_seg(job_id)}/params", _json)


def list_jobs(state: str | None = None, limit: int = 50, offset: int = 0) -> Call[JobList]:
    """One page of the caller's jobs, newest first."""
    params = _drop_none({"state": state, "limit": limit, "offset": offset})
    return Call("GET", "/v1/jobs", _model(JobList), params=params)


def delete_job(job_id: str) -> Call[JobPublic | None]:
    """Cancel a queued/running job (returns it, cancelled) or delete a finished one (None)."""
    return Call("DELETE", f"/v1/jobs/{_seg(job_id)}", _job_or_none, ok=(200, 204))


# --------------------------------------------------------------------------- artifacts


def artifact_path(job_id: str, name: str) -> str:
    # artifact names may contain '/', e.g. frames/000.glb
    return f"/v1/jobs/{_seg(job_id)}/artifacts/{quote(name, safe='/')}"


def events_path(job_id: str) -> str:
    return f"/v1/jobs/{_seg(job_id)}/events"


def get_artifact(
    job_id: str, name: str, *, byte_range: tuple[int, int | None] | None = None
) -> Call[bytes]:
    """An artifact's bytes (or a ``(first, last)`` byte range of it; last may be None)."""
    headers = {}
    if byte_range is not None:
        a, b = byte_range
        headers["Range"] = f"bytes={a}-{'' if b is None else b}"
    return Call(
        "GET",
        artifact_path(job_id, name),
        lambda r: r.content,
        ok=(200, 206),
        headers=headers,
    )


def head_artifact(job_id: str, name: str) -> Call[ArtifactLink]:
    """An artifact's content type, size and ETag (``HEAD``: nothing is downloaded)."""
    path = artifact_path(job_id, name)

    def parse(r: httpx.Response) -> ArtifactLink:
        return ArtifactLink(
            name=name,
            url=path,
            content_type=r.headers["content-type"],
            size=int(r.headers["content-length"]),
            etag=r.headers["etag"].strip('"'),
        )

    return Call("HEAD", path, parse)
