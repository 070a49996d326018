"""Every endpoint once, as a description of the request and how to read its answer.

The sync and async clients differ only in how they send a :class:`Call`; what
to send and how to parse the answer lives here, so the two cannot drift.
"""

from __future__ import annotations

import json
import mimetypes
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar
from urllib.parse import quote

import httpx
from pydantic import BaseModel

from conformorph_client.errors import error_from_response
from conformorph_client.models import (
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

    def check(self, response: httpx.Response) -> T:
        """Parse a read response, raising the typed error for an error status."""
        if response.status_code not in self.ok:
            raise error_from_response(response)
        return self.parse(response)


def _model(model: type[M]) -> Callable[[httpx.Response], M]:
    return lambda r: model.model_validate_json(r.content)


def _job_or_none(r: httpx.Response) -> JobPublic | None:
    return None if r.status_code == 204 else JobPublic.model_validate_json(r.content)


def _seg(value: str) -> str:
    """An id as one URL path segment (so ``../x`` cannot change the route)."""
    if not value:
        raise ValueError("an id must not be empty")
    return quote(value, safe="")


def upload_parts(source: UploadSource) -> tuple[str, Any, str]:
    """(file name, bytes or open file, content type) for a multipart ``file`` field.

    The caller closes the file when one is opened (see :func:`close_upload`).
    """
    if isinstance(source, tuple):
        name, data = source
        return name, data, mimetypes.guess_type(name)[0] or "application/octet-stream"
    p = Path(source)
    return p.name, open(p, "rb"), mimetypes.guess_type(p.name)[0] or "application/octet-stream"  # noqa: SIM115


def close_upload(part: tuple[str, Any, str]) -> None:
    if hasattr(part[1], "close"):
        part[1].close()


def _idem(key: str | None) -> dict[str, str]:
    return {"Idempotency-Key": key} if key is not None else {}


# --------------------------------------------------------------------------- endpoints


def healthz() -> Call[Health]:
    return Call("GET", "/healthz", _model(Health))


def readyz() -> Call[Readiness]:
    # 503 carries the same body, saying which dependency is down
    return Call("GET", "/readyz", _model(Readiness), ok=(200, 503))


def upload_mesh(source: UploadSource) -> Call[MeshPublic]:
    return Call("POST", "/v1/meshes", _model(MeshPublic), ok=(200, 201), upload=source)


def get_mesh(mesh_id: str) -> Call[MeshPublic]:
    return Call("GET", f"/v1/meshes/{_seg(mesh_id)}", _model(MeshPublic))


def upload_texture(source: UploadSource) -> Call[TexturePublic]:
    return Call("POST", "/v1/textures", _model(TexturePublic), ok=(200, 201), upload=source)


def get_texture(texture_id: str) -> Call[TexturePublic]:
    return Call("GET", f"/v1/textures/{_seg(texture_id)}", _model(TexturePublic))


def upload_shape(source: UploadSource) -> Call[ShapePublic]:
    return Call("POST", "/v1/shapes", _model(ShapePublic), ok=(200, 201), upload=source)


def get_shape(shape_id: str) -> Call[ShapePublic]:
    return Call("GET", f"/v1/shapes/{_seg(shape_id)}", _model(ShapePublic))


def upload_landmarks(document: dict[str, Any]) -> Call[LandmarkSetPublic]:
    """``POST /v1/landmarks`` with a landmark document (any layout the server reads)."""
    return Call("POST", "/v1/landmarks", _model(LandmarkSetPublic), ok=(200, 201), json=document)


def get_landmarks(set_id: str) -> Call[LandmarkSetPublic]:
    return Call("GET", f"/v1/landmarks/{_seg(set_id)}", _model(LandmarkSetPublic))


def _drop_none(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if v is not None}


def create_conformal_map(
    mesh: str,
    *,
    method: str = "fast",
    center_vertex: int | None = None,
    angle_vertex: int | None = None,
    idempotency_key: str | None = None,
) -> Call[JobPublic]:
    body = _drop_none(
        {
            "mesh": mesh,
            "method": method,
            "center_vertex": center_vertex,
            "angle_vertex": angle_vertex,
        }
    )
    return Call(
        "POST",
        "/v1/conformal-maps",
        _model(JobPublic),
        ok=(200, 202),
        json=body,
        headers=_idem(idempotency_key),
    )


def create_reconstruction(
    mesh: str,
    *,
    method: str = "fast",
    curvature: str = "vector",
    idempotency_key: str | None = None,
) -> Call[JobPublic]:
    body = {"mesh": mesh, "method": method, "curvature": curvature}
    return Call(
        "POST",
        "/v1/reconstructions",
        _model(JobPublic),
        ok=(200, 202),
        json=body,
        headers=_idem(idempotency_key),
    )


def create_morph(
    meshes: Sequence[str],
    *,
    landmarks: Sequence[Sequence[Any]] | None = None,
    landmarks_id: str | None = None,
    times: Sequence[float] | None = None,
    frames: int | None = None,
    method: str | None = None,
    curvature: str | None = None,
    consistent: str | None = None,
    textures: Sequence[str] | None = None,
    per_frame: bool | None = None,
    extra: dict[str, Any] | None = None,
    idempotency_key: str | None = None,
) -> Call[JobPublic]:
    """``POST /v1/morphs``; parameters left ``None`` take the server's defaults."""
    body = _drop_none(
        {
            "meshes": list(meshes),
            "landmarks": [list(x) for x in landmarks] if landmarks is not None else None,
            "landmarks_id": landmarks_id,
            "times": list(times) if times is not None else None,
            "frames": frames,
            "method": method,
            "curvature": curvature,
            "consistent": consistent,
            "textures": list(textures) if textures is not None else None,
            "per_frame": per_frame,
        }
    )
    body.update(extra or {})
    return Call(
        "POST",
        "/v1/morphs",
        _model(JobPublic),
        ok=(200, 202),
        json=body,
        headers=_idem(idempotency_key),
    )


def create_morph2d(
    source: str,
    target: str,
    *,
    anchors: Sequence[Sequence[Sequence[float]]],
    frames: int | None = None,
    interp: str | None = None,
    per_frame: bool | None = None,
    texture: str | None = None,
    idempotency_key: str | None = None,
) -> Call[JobPublic]:
    """``POST /v1/morphs2d``: a 2D strain-field morph between two uploaded shapes."""
    body = _drop_none(
        {
            "source": source,
            "target": target,
            "anchors": [[list(p) for p in pair] for pair in anchors],
            "frames": frames,
            "interp": interp,
            "per_frame": per_frame,
            "texture": texture,
        }
    )
    return Call(
        "POST",
        "/v1/morphs2d",
        _model(JobPublic),
        ok=(200, 202),
        json=body,
        headers=_idem(idempotency_key),
    )


def get_job(job_id: str) -> Call[JobPublic]:
    return Call("GET", f"/v1/jobs/{_seg(job_id)}", _model(JobPublic))


def list_jobs(state: str | None = None, limit: int = 50, offset: int = 0) -> Call[JobList]:
    params = _drop_none({"state": state, "limit": limit, "offset": offset})
    return Call("GET", "/v1/jobs", _model(JobList), params=params)


def delete_job(job_id: str) -> Call[JobPublic | None]:
    """Cancel (answer: the job, now cancelled) or delete a finished job (answer: None)."""
    return Call("DELETE", f"/v1/jobs/{_seg(job_id)}", _job_or_none, ok=(200, 204))


def artifact_path(job_id: str, name: str) -> str:
    # artifact names may contain '/', e.g. frames/000.glb
    return f"/v1/jobs/{_seg(job_id)}/artifacts/{quote(name, safe='/')}"


def events_path(job_id: str) -> str:
    return f"/v1/jobs/{_seg(job_id)}/events"


def get_artifact(job_id: str, name: str, byte_range: tuple[int, int | None] | None) -> Call[bytes]:
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


# --------------------------------------------------------------------------- events


@dataclass
class SSEParser:
    """Incremental parser of a ``text/event-stream`` (one line at a time)."""

    _event: str = ""
    _data: list[str] = field(default_factory=list)

    def feed(self, line: str) -> tuple[str, str] | None:
        """Feed one line (without its newline); returns ``(event, data)`` when one completes."""
        if line == "":
            if not self._data and not self._event:
                return None
            out = (self._event or "message", "\n".join(self._data))
            self._event, self._data = "", []
            return out
        if line.startswith(":"):
            return None
        name, _, value = line.partition(":")
        value = value.removeprefix(" ")
        if name == "event":
            self._event = value
        elif name == "data":
            self._data.append(value)
        return None


def event_job(event: str, data: str) -> JobPublic | None:
    """The job carried by a ``state`` event; None for other events."""
    if event != "state":
        return None
    return JobPublic.model_validate(json.loads(data))
