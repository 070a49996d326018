"""Every endpoint once, as a description of the request and how to read its answer.

The sync and async clients differ only in how they send a :class:`Call`; what
to send and how to parse the answer lives here, so the two cannot drift. So do
the pieces of the longer flows both clients run (sending a call, reading an
event stream, paging, downloading, following a job to its end): the clients
keep only the I/O (``await`` or not).
"""

from __future__ import annotations

import json
import mimetypes
import os
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar
from urllib.parse import quote

import httpx
from pydantic import BaseModel

from conformorph_client.errors import (
    JobCancelled,
    JobFailed,
    TransportError,
    WaitTimeout,
    error_from_response,
)
from conformorph_client.models import (
    TERMINAL_STATES,
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
    refine_angles: bool | None = None,
    fill_holes: bool | None = None,
    remove_ears: bool | None = None,
) -> Call[JobPublic]:
    body = _drop_none(
        {
            "mesh": mesh,
            "method": method,
            "center_vertex": center_vertex,
            "angle_vertex": angle_vertex,
            "refine_angles": refine_angles,
            "fill_holes": fill_holes,
            "remove_ears": remove_ears,
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
    fill_holes: bool | None = None,
    remove_ears: bool | None = None,
    fold_correction: bool | None = None,
) -> Call[JobPublic]:
    body = _drop_none(
        {
            "mesh": mesh,
            "method": method,
            "curvature": curvature,
            "fill_holes": fill_holes,
            "remove_ears": remove_ears,
            "fold_correction": fold_correction,
        }
    )
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
    normals: bool | None = None,
    extra: dict[str, Any] | None = None,
    idempotency_key: str | None = None,
    frame_times: Sequence[float] | None = None,
    refine: str | None = None,
    fill_holes: bool | None = None,
    remove_ears: bool | None = None,
) -> Call[JobPublic]:
    """``POST /v1/morphs``; parameters left ``None`` take the server's defaults."""
    body = _drop_none(
        {
            "meshes": list(meshes),
            "landmarks": [list(x) for x in landmarks] if landmarks is not None else None,
            "landmarks_id": landmarks_id,
            "times": list(times) if times is not None else None,
            "frames": frames,
            "frame_times": list(frame_times) if frame_times is not None else None,
            "method": method,
            "refine": refine,
            "curvature": curvature,
            "consistent": consistent,
            "textures": list(textures) if textures is not None else None,
            "per_frame": per_frame,
            "normals": normals,
            "fill_holes": fill_holes,
            "remove_ears": remove_ears,
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
    pace: str | None = None,
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
            "pace": pace,
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


def head_artifact(job_id: str, name: str) -> Call[ArtifactLink]:
    """``HEAD`` of an artifact: its type, size and ETag from the headers, no bytes."""
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


class JobEvents:
    """A job's event stream read line by line: the job of every ``state`` event, up to ``end``."""

    def __init__(self) -> None:
        self._parser = SSEParser()
        #: true once the server's ``end`` event has been read
        self.ended = False

    def feed(self, line: str) -> JobPublic | None:
        """Feed one line; returns the job when a ``state`` event completes."""
        ev = self._parser.feed(line)
        if ev is None:
            return None
        if ev[0] == "end":
            self.ended = True
            return None
        return event_job(*ev)


def events_request(job_id: str, read_timeout: float | None) -> dict[str, Any]:
    """Keyword arguments of ``httpx`` ``stream`` for a job's event stream (no read
    timeout unless given: the server sends a keep-alive every 15 s)."""
    return {
        "method": "GET",
        "url": events_path(job_id),
        "headers": {"Accept": "text/event-stream"},
        "timeout": httpx.Timeout(read_timeout, connect=10.0),
    }


# --------------------------------------------------------------------------- shared flows


@contextmanager
def transport_errors(what: str) -> Iterator[None]:
    """Turn an ``httpx`` transport failure inside the block into :class:`TransportError`."""
    try:
        yield
    except httpx.TransportError as exc:
        raise TransportError(f"{what}: {exc}") from exc


#: transport failures after which a repeatable call is sent once more: the server
#: closed a pooled keep-alive connection while it sat idle (the request met a closed
#: socket: "Server disconnected without sending a response"), a race every HTTP client
#: that reuses connections meets when its pause matches the server's idle timeout
RESENT_AFTER = (httpx.RemoteProtocolError, httpx.ReadError, httpx.WriteError)


def may_resend(repeatable: bool, error: TransportError, attempt: int) -> bool:
    """Whether a request, failed on its ``attempt``-th send (0-based) with ``error``, is
    sent again: once, and only when it is ``repeatable`` (:attr:`Call.repeatable`; every
    download) and the failure is one of :data:`RESENT_AFTER`."""
    return attempt == 0 and repeatable and isinstance(error.__cause__, RESENT_AFTER)


@contextmanager
def sending(call: Call[Any], base_url: str) -> Iterator[dict[str, Any]]:
    """Keyword arguments of ``httpx`` ``request`` for ``call``.

    Opens the call's upload for the block and closes it after; a transport
    failure becomes :class:`TransportError` naming the request.
    """
    part = upload_parts(call.upload) if call.upload is not None else None
    try:
        with transport_errors(f"{call.method} {base_url}{call.path}"):
            yield {
                "method": call.method,
                "url": call.path,
                "params": call.params,
                "json": call.json,
                "headers": call.headers,
                "files": {"file": part} if part is not None else None,
            }
    finally:
        if part is not None:
            close_upload(part)


def next_offset(offset: int, page: JobList) -> int | None:
    """Offset of the page after ``page`` (read at ``offset``), or None after the last one."""
    offset += len(page.items)
    if not page.items or offset >= page.total:
        return None
    return offset


@contextmanager
def download_to(dest: str | os.PathLike[str], what: str) -> Iterator[Path]:
    """The ``.part`` file to stream a download into; renamed to ``dest`` when the block
    succeeds, removed when it fails (a transport failure becomes :class:`TransportError`)."""
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    part = dest.with_name(dest.name + ".part")
    try:
        with transport_errors(what):
            yield part
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    os.replace(part, dest)


class JobFollower:
    """What both clients' ``wait`` share: progress callbacks, the end test, the
    deadline and the final verdict on the job.

    Parameters
    ----------
    job_id : str
    timeout : float, optional
        Seconds from now; None waits for ever.
    on_update : callable, optional
        Called with every job state seen.
    raise_on_failure : bool
        Whether :meth:`result` raises for a failed or cancelled job.
    """

    def __init__(
        self,
        job_id: str,
        timeout: float | None,
        on_update: Callable[[JobPublic], None] | None,
        raise_on_failure: bool,
    ) -> None:
        self.job_id = job_id
        self.timeout = timeout
        self.deadline = None if timeout is None else time.monotonic() + timeout
        self._on_update = on_update
        self._raise_on_failure = raise_on_failure

    def update(self, job: JobPublic) -> JobPublic:
        """Report one job state to the callback; returns the job."""
        if self._on_update:
            self._on_update(job)
        return job

    @staticmethod
    def running(job: JobPublic) -> bool:
        """Whether the job has not ended yet."""
        return job.state not in TERMINAL_STATES

    def expired(self) -> bool:
        return self.deadline is not None and time.monotonic() > self.deadline

    def read_timeout(self) -> float | None:
        """Read timeout of the event stream: the time left (at least 1 s), or None."""
        return None if self.deadline is None else max(1.0, self.deadline - time.monotonic())

    def check_deadline(self, job: JobPublic) -> None:
        """Raise :class:`WaitTimeout` if the deadline has passed with ``job`` still running."""
        if self.expired():
            raise WaitTimeout(f"job {self.job_id} still {job.state} after {self.timeout} s")

    def timed_out(self) -> WaitTimeout:
        """The error for a wait cut off at the deadline (the async client's form)."""
        return WaitTimeout(f"job {self.job_id} did not finish within {self.timeout} s")

    def result(self, job: JobPublic) -> JobPublic:
        """The ended job, or :class:`JobFailed` / :class:`JobCancelled` if asked to raise."""
        if self._raise_on_failure and job.state == "failed":
            raise JobFailed(job)
        if self._raise_on_failure and job.state == "cancelled":
            raise JobCancelled(job)
        return job
