"""Sync and async clients for the conformorph REST API (httpx).

>>> from conformorph_client import Client
>>> with Client("http://127.0.0.1:8000", api_key=None) as c:  # doctest: +SKIP
...     a = c.upload_mesh("face0.obj")
...     job = c.create_conformal_map(a.id)
...     job = c.wait(job.id)
...     c.download(job.id, "disk_map.npz", "out/disk_map.npz")

Every error status raises a subclass of :class:`~conformorph_client.errors.ApiError`
carrying the server's ``type``, ``message`` and ``field``; a job that ends
failed raises :class:`~conformorph_client.errors.JobFailed` from :meth:`Client.wait`.
"""

from __future__ import annotations

import asyncio
import os
import time
from collections.abc import AsyncIterator, Callable, Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, TypeVar

import httpx

from conformorph_client import _calls
from conformorph_client._calls import Call, JobEvents, JobFollower, UploadSource
from conformorph_client.errors import TransportError, error_from_response
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
ProgressCallback = Callable[[JobPublic], None]

#: longer than the server's own waits (an upload waits up to 60 s for a worker to validate it),
#: so that the server's answer, not a client time-out, reaches the caller
DEFAULT_TIMEOUT = httpx.Timeout(120.0, connect=10.0)
_CHUNK = 256 * 1024


def _headers(api_key: str | None) -> dict[str, str]:
    h = {"Accept": "application/json", "User-Agent": "conformorph-client/0.1"}
    if api_key:
        h["Authorization"] = f"Bearer {api_key}"
    return h


def _raise_for_stream(r: httpx.Response) -> None:
    """Raise the typed error of a streamed answer that is not a 200."""
    if r.status_code != 200:
        r.read()
        raise error_from_response(r)


async def _araise_for_stream(r: httpx.Response) -> None:
    """:func:`_raise_for_stream` for the async client."""
    if r.status_code != 200:
        await r.aread()
        raise error_from_response(r)


class Client:
    """Blocking client.

    Parameters
    ----------
    base_url : str
        The server, e.g. ``http://127.0.0.1:8000``.
    api_key : str, optional
        Sent as ``Authorization: Bearer <key>``; leave out for a server running open.
    timeout : float or httpx.Timeout
        Per-request timeout (event streams have no read timeout).
    transport : httpx.BaseTransport, optional
        For tests or custom networking.
    """

    def __init__(
        self,
        base_url: str,
        api_key: str | None = None,
        *,
        timeout: float | httpx.Timeout = DEFAULT_TIMEOUT,
        transport: httpx.BaseTransport | None = None,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self._http = httpx.Client(
            base_url=self.base_url, headers=_headers(api_key), timeout=timeout, transport=transport
        )

    # -- plumbing
    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _run(self, call: Call[T]) -> T:
        for attempt in range(2):
            try:
                with _calls.sending(call, self.base_url) as request:
                    r = self._http.request(**request)
                break
            except TransportError as exc:
                if not _calls.may_resend(call.repeatable, exc, attempt):
                    raise
        return call.check(r)

    # -- health
    def healthz(self) -> Health:
        """``GET /healthz``."""
        return self._run(_calls.healthz())

    def readyz(self) -> Readiness:
        """``GET /readyz`` (a 503 answer is returned too: see ``status`` and ``checks``)."""
        return self._run(_calls.readyz())

    # -- inputs
    def upload_mesh(self, source: UploadSource) -> MeshPublic:
        """Upload a mesh file (path, or ``(name, bytes)``); the same bytes give the same id."""
        return self._run(_calls.upload_mesh(source))

    def get_mesh(self, mesh_id: str) -> MeshPublic:
        return self._run(_calls.get_mesh(mesh_id))

    def upload_texture(self, source: UploadSource) -> TexturePublic:
        """Upload a PNG or JPEG texture."""
        return self._run(_calls.upload_texture(source))

    def get_texture(self, texture_id: str) -> TexturePublic:
        return self._run(_calls.get_texture(texture_id))

    def upload_landmarks(self, document: dict[str, Any]) -> LandmarkSetPublic:
        """Upload a landmark document; use its id as ``landmarks_id`` in a morph."""
        return self._run(_calls.upload_landmarks(document))

    def get_landmarks(self, set_id: str) -> LandmarkSetPublic:
        return self._run(_calls.get_landmarks(set_id))

    # -- jobs
    def create_conformal_map(
        self,
        mesh: str,
        *,
        method: str = "fast",
        center_vertex: int | None = None,
        angle_vertex: int | None = None,
        idempotency_key: str | None = None,
        refine_angles: bool | None = None,
        fill_holes: bool | None = None,
        remove_ears: bool | None = None,
    ) -> JobPublic:
        """``POST /v1/conformal-maps``: start a disk-map job."""
        return self._run(
            _calls.create_conformal_map(
                mesh,
                method=method,
                center_vertex=center_vertex,
                angle_vertex=angle_vertex,
                idempotency_key=idempotency_key,
                refine_angles=refine_angles,
                fill_holes=fill_holes,
                remove_ears=remove_ears,
            )
        )

    def create_reconstruction(
        self,
        mesh: str,
        *,
        method: str = "fast",
        curvature: str = "vector",
        idempotency_key: str | None = None,
        fill_holes: bool | None = None,
        remove_ears: bool | None = None,
        fold_correction: bool | None = None,
    ) -> JobPublic:
        """``POST /v1/reconstructions``: start a map + (H, λ) + reconstruction job."""
        return self._run(
            _calls.create_reconstruction(
                mesh,
                method=method,
                curvature=curvature,
                idempotency_key=idempotency_key,
                fill_holes=fill_holes,
                remove_ears=remove_ears,
                fold_correction=fold_correction,
            )
        )

    def create_morph(
        self,
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
    ) -> JobPublic:
        """``POST /v1/morphs``: start a face-morph job over uploaded meshes."""
        return self._run(
            _calls.create_morph(
                meshes,
                landmarks=landmarks,
                landmarks_id=landmarks_id,
                times=times,
                frames=frames,
                method=method,
                curvature=curvature,
                consistent=consistent,
                textures=textures,
                per_frame=per_frame,
                normals=normals,
                extra=extra,
                idempotency_key=idempotency_key,
                frame_times=frame_times,
                refine=refine,
                fill_holes=fill_holes,
                remove_ears=remove_ears,
            )
        )

    def upload_shape(self, source: UploadSource) -> ShapePublic:
        """Upload a 2D shape (JSON rings or SVG) for 2D morphs."""
        return self._run(_calls.upload_shape(source))

    def get_shape(self, shape_id: str) -> ShapePublic:
        return self._run(_calls.get_shape(shape_id))

    def create_morph2d(
        self,
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
    ) -> JobPublic:
        """``POST /v1/morphs2d``: start a 2D strain-field morph between two shapes."""
        return self._run(
            _calls.create_morph2d(
                source,
                target,
                anchors=anchors,
                frames=frames,
                interp=interp,
                per_frame=per_frame,
                texture=texture,
                idempotency_key=idempotency_key,
                pace=pace,
            )
        )

    def get_job(self, job_id: str) -> JobPublic:
        return self._run(_calls.get_job(job_id))

    def list_jobs(self, state: str | None = None, limit: int = 50, offset: int = 0) -> JobList:
        """One page of the caller's jobs, newest first."""
        return self._run(_calls.list_jobs(state, limit, offset))

    def iter_jobs(self, state: str | None = None, page_size: int = 100) -> Iterator[JobPublic]:
        """Every job of the caller, page after page."""
        offset: int | None = 0
        while offset is not None:
            page = self.list_jobs(state, page_size, offset)
            yield from page.items
            offset = _calls.next_offset(offset, page)

    def delete_job(self, job_id: str) -> JobPublic | None:
        """Cancel a queued/running job (returns it, cancelled) or delete a finished one (None)."""
        return self._run(_calls.delete_job(job_id))

    cancel_job = delete_job

    def events(self, job_id: str, *, read_timeout: float | None = None) -> Iterator[JobPublic]:
        """The job's server-sent ``state`` events until it ends.

        ``read_timeout`` bounds the silence between two chunks (the server sends a
        keep-alive every 15 s); None waits for ever.
        """
        stream = JobEvents()
        with (
            _calls.transport_errors(f"event stream of job {job_id}"),
            self._http.stream(**_calls.events_request(job_id, read_timeout)) as r,
        ):
            _raise_for_stream(r)
            for line in r.iter_lines():
                job = stream.feed(line)
                if stream.ended:
                    return
                if job is not None:
                    yield job

    def wait(
        self,
        job_id: str,
        *,
        timeout: float | None = None,
        on_update: ProgressCallback | None = None,
        raise_on_failure: bool = True,
        poll_interval: float = 0.5,
    ) -> JobPublic:
        """Follow a job (its event stream, polling if the stream breaks) until it ends.

        Raises :class:`JobFailed` / :class:`JobCancelled` unless ``raise_on_failure``
        is false, and :class:`WaitTimeout` after ``timeout`` seconds.
        """
        follower = JobFollower(job_id, timeout, on_update, raise_on_failure)
        job = follower.update(self.get_job(job_id))
        if follower.running(job):
            try:
                for job in self.events(job_id, read_timeout=follower.read_timeout()):
                    follower.update(job)
                    if follower.expired():
                        break
            except TransportError:
                pass  # the stream broke or went quiet: poll instead
            job = self.get_job(job_id)
        while follower.running(job):
            follower.check_deadline(job)
            time.sleep(poll_interval)
            job = follower.update(self.get_job(job_id))
        return follower.result(job)

    # -- artifacts
    def get_artifact(
        self, job_id: str, name: str, *, byte_range: tuple[int, int | None] | None = None
    ) -> bytes:
        """An artifact's bytes (or a ``(first, last)`` byte range of it; last may be None)."""
        return self._run(_calls.get_artifact(job_id, name, byte_range))

    def head_artifact(self, job_id: str, name: str) -> ArtifactLink:
        """An artifact's content type, size and ETag (``HEAD``: nothing is downloaded)."""
        return self._run(_calls.head_artifact(job_id, name))

    def download(self, job_id: str, name: str, dest: str | os.PathLike[str]) -> Path:
        """Stream an artifact to ``dest`` (written to ``dest.part``, then renamed)."""
        for attempt in range(2):
            try:
                with (
                    _calls.download_to(dest, f"download of {name} from job {job_id}") as part,
                    self._http.stream("GET", _calls.artifact_path(job_id, name)) as r,
                ):
                    _raise_for_stream(r)
                    with open(part, "wb") as f:
                        for chunk in r.iter_bytes(_CHUNK):
                            f.write(chunk)
                break
            except TransportError as exc:
                if not _calls.may_resend(True, exc, attempt):
                    raise
        return Path(dest)


class AsyncClient:
    """The same API as :class:`Client`, with ``async`` methods."""

    def __init__(
        self,
        base_url: str,
        api_key: str | None = None,
        *,
        timeout: float | httpx.Timeout = DEFAULT_TIMEOUT,
        transport: httpx.AsyncBaseTransport | None = None,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self._http = httpx.AsyncClient(
            base_url=self.base_url, headers=_headers(api_key), timeout=timeout, transport=transport
        )

    async def aclose(self) -> None:
        await self._http.aclose()

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.aclose()

    async def _run(self, call: Call[T]) -> T:
        for attempt in range(2):
            try:
                with _calls.sending(call, self.base_url) as request:
                    r = await self._http.request(**request)
                break
            except TransportError as exc:
                if not _calls.may_resend(call.repeatable, exc, attempt):
                    raise
        return call.check(r)

    async def healthz(self) -> Health:
        return await self._run(_calls.healthz())

    async def readyz(self) -> Readiness:
        return await self._run(_calls.readyz())

    async def upload_mesh(self, source: UploadSource) -> MeshPublic:
        return await self._run(_calls.upload_mesh(source))

    async def get_mesh(self, mesh_id: str) -> MeshPublic:
        return await self._run(_calls.get_mesh(mesh_id))

    async def upload_texture(self, source: UploadSource) -> TexturePublic:
        return await self._run(_calls.upload_texture(source))

    async def get_texture(self, texture_id: str) -> TexturePublic:
        return await self._run(_calls.get_texture(texture_id))

    async def upload_landmarks(self, document: dict[str, Any]) -> LandmarkSetPublic:
        """Upload a landmark document; use its id as ``landmarks_id`` in a morph."""
        return await self._run(_calls.upload_landmarks(document))

    async def get_landmarks(self, set_id: str) -> LandmarkSetPublic:
        return await self._run(_calls.get_landmarks(set_id))

    async def create_conformal_map(
        self,
        mesh: str,
        *,
        method: str = "fast",
        center_vertex: int | None = None,
        angle_vertex: int | None = None,
        idempotency_key: str | None = None,
        refine_angles: bool | None = None,
        fill_holes: bool | None = None,
        remove_ears: bool | None = None,
    ) -> JobPublic:
        return await self._run(
            _calls.create_conformal_map(
                mesh,
                method=method,
                center_vertex=center_vertex,
                angle_vertex=angle_vertex,
                idempotency_key=idempotency_key,
                refine_angles=refine_angles,
                fill_holes=fill_holes,
                remove_ears=remove_ears,
            )
        )

    async def create_reconstruction(
        self,
        mesh: str,
        *,
        method: str = "fast",
        curvature: str = "vector",
        idempotency_key: str | None = None,
        fill_holes: bool | None = None,
        remove_ears: bool | None = None,
        fold_correction: bool | None = None,
    ) -> JobPublic:
        return await self._run(
            _calls.create_reconstruction(
                mesh,
                method=method,
                curvature=curvature,
                idempotency_key=idempotency_key,
                fill_holes=fill_holes,
                remove_ears=remove_ears,
                fold_correction=fold_correction,
            )
        )

    async def create_morph(
        self,
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
    ) -> JobPublic:
        return await self._run(
            _calls.create_morph(
                meshes,
                landmarks=landmarks,
                landmarks_id=landmarks_id,
                times=times,
                frames=frames,
                method=method,
                curvature=curvature,
                consistent=consistent,
                textures=textures,
                per_frame=per_frame,
                normals=normals,
                extra=extra,
                idempotency_key=idempotency_key,
                frame_times=frame_times,
                refine=refine,
                fill_holes=fill_holes,
                remove_ears=remove_ears,
            )
        )

    async def upload_shape(self, source: UploadSource) -> ShapePublic:
        return await self._run(_calls.upload_shape(source))

    async def get_shape(self, shape_id: str) -> ShapePublic:
        return await self._run(_calls.get_shape(shape_id))

    async def create_morph2d(
        self,
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
    ) -> JobPublic:
        return await self._run(
            _calls.create_morph2d(
                source,
                target,
                anchors=anchors,
                frames=frames,
                interp=interp,
                per_frame=per_frame,
                texture=texture,
                idempotency_key=idempotency_key,
                pace=pace,
            )
        )

    async def get_job(self, job_id: str) -> JobPublic:
        return await self._run(_calls.get_job(job_id))

    async def list_jobs(
        self, state: str | None = None, limit: int = 50, offset: int = 0
    ) -> JobList:
        return await self._run(_calls.list_jobs(state, limit, offset))

    async def iter_jobs(
        self, state: str | None = None, page_size: int = 100
    ) -> AsyncIterator[JobPublic]:
        offset: int | None = 0
        while offset is not None:
            page = await self.list_jobs(state, page_size, offset)
            for job in page.items:
                yield job
            offset = _calls.next_offset(offset, page)

    async def delete_job(self, job_id: str) -> JobPublic | None:
        return await self._run(_calls.delete_job(job_id))

    cancel_job = delete_job

    async def events(
        self, job_id: str, *, read_timeout: float | None = None
    ) -> AsyncIterator[JobPublic]:
        stream = JobEvents()
        with _calls.transport_errors(f"event stream of job {job_id}"):
            async with self._http.stream(**_calls.events_request(job_id, read_timeout)) as r:
                await _araise_for_stream(r)
                async for line in r.aiter_lines():
                    job = stream.feed(line)
                    if stream.ended:
                        return
                    if job is not None:
                        yield job

    async def wait(
        self,
        job_id: str,
        *,
        timeout: float | None = None,
        on_update: ProgressCallback | None = None,
        raise_on_failure: bool = True,
        poll_interval: float = 0.5,
    ) -> JobPublic:
        follower = JobFollower(job_id, timeout, on_update, raise_on_failure)

        async def follow() -> JobPublic:
            # the time limit is asyncio.wait_for's below, so the stream needs no read timeout
            job = follower.update(await self.get_job(job_id))
            if follower.running(job):
                try:
                    async for job in self.events(job_id):
                        follower.update(job)
                except TransportError:
                    pass  # the stream broke: poll instead
                job = await self.get_job(job_id)
            while follower.running(job):
                await asyncio.sleep(poll_interval)
                job = follower.update(await self.get_job(job_id))
            return job

        try:
            job = await asyncio.wait_for(follow(), timeout)
        except TimeoutError as exc:
            raise follower.timed_out() from exc
        return follower.result(job)

    async def get_artifact(
        self, job_id: str, name: str, *, byte_range: tuple[int, int | None] | None = None
    ) -> bytes:
        return await self._run(_calls.get_artifact(job_id, name, byte_range))

    async def head_artifact(self, job_id: str, name: str) -> ArtifactLink:
        return await self._run(_calls.head_artifact(job_id, name))

    async def download(self, job_id: str, name: str, dest: str | os.PathLike[str]) -> Path:
        for attempt in range(2):
            try:
                with _calls.download_to(dest, f"download of {name} from job {job_id}") as part:
                    async with self._http.stream("GET", _calls.artifact_path(job_id, name)) as r:
                        await _araise_for_stream(r)
                        with open(part, "wb") as f:
                            async for chunk in r.aiter_bytes(_CHUNK):
                                f.write(chunk)
                break
            except TransportError as exc:
                if not _calls.may_resend(True, exc, attempt):
                    raise
        return Path(dest)
