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
from collections.abc import AsyncIterator, Callable, Iterator
from pathlib import Path
from types import TracebackType
from typing import TypeVar

import httpx

from conformorph_client import _calls, _flows
from conformorph_client._calls import Call
from conformorph_client._endpoint import AsyncExecutor, Endpoint, SyncExecutor
from conformorph_client._flows import JobEvents, JobFollower
from conformorph_client.errors import TransportError, error_from_response
from conformorph_client.models import JobPublic

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


class _Endpoints:
    """Every endpoint, once: a method of both clients (see :class:`Endpoint`), with
    the parameters and docstring of its builder in :mod:`conformorph_client._calls`."""

    # -- health
    healthz = Endpoint(_calls.healthz)
    readyz = Endpoint(_calls.readyz)
    # -- inputs
    upload_mesh = Endpoint(_calls.upload_mesh)
    get_mesh = Endpoint(_calls.get_mesh)
    upload_texture = Endpoint(_calls.upload_texture)
    get_texture = Endpoint(_calls.get_texture)
    upload_landmarks = Endpoint(_calls.upload_landmarks)
    get_landmarks = Endpoint(_calls.get_landmarks)
    get_landmark_document = Endpoint(_calls.get_landmark_document)
    upload_shape = Endpoint(_calls.upload_shape)
    get_shape = Endpoint(_calls.get_shape)
    # -- jobs
    create_conformal_map = Endpoint(_calls.create_conformal_map)
    create_reconstruction = Endpoint(_calls.create_reconstruction)
    create_morph = Endpoint(_calls.create_morph)
    detect_landmarks = Endpoint(_calls.detect_landmarks)
    create_morph2d = Endpoint(_calls.create_morph2d)
    get_job = Endpoint(_calls.get_job)
    get_job_params = Endpoint(_calls.get_job_params)
    list_jobs = Endpoint(_calls.list_jobs)
    delete_job = Endpoint(_calls.delete_job)
    cancel_job = delete_job
    # -- artifacts
    get_artifact = Endpoint(_calls.get_artifact)
    head_artifact = Endpoint(_calls.head_artifact)


class Client(_Endpoints, SyncExecutor):
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
        # artifacts on object storage may be a redirect to a presigned URL (httpx drops
        # the Authorization header when a redirect leaves the server's origin)
        self._http = httpx.Client(
            base_url=self.base_url,
            headers=_headers(api_key),
            timeout=timeout,
            transport=transport,
            follow_redirects=True,
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
                with _flows.sending(call, self.base_url) as request:
                    r = self._http.request(**request)
                break
            except TransportError as exc:
                if not _flows.may_resend(call.repeatable, exc, attempt):
                    raise
        return call.check(r)

    def iter_jobs(self, state: str | None = None, page_size: int = 100) -> Iterator[JobPublic]:
        """Every job of the caller, page after page."""
        offset: int | None = 0
        while offset is not None:
            page = self.list_jobs(state, page_size, offset)
            yield from page.items
            offset = _flows.next_offset(offset, page)

    def events(self, job_id: str, *, read_timeout: float | None = None) -> Iterator[JobPublic]:
        """The job's server-sent ``state`` events until it ends.

        ``read_timeout`` bounds the silence between two chunks (the server sends a
        keep-alive every 15 s); None waits for ever.
        """
        stream = JobEvents()
        with (
            _flows.transport_errors(f"event stream of job {job_id}"),
            self._http.stream(**_flows.events_request(job_id, read_timeout)) as r,
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

    def download(self, job_id: str, name: str, dest: str | os.PathLike[str]) -> Path:
        """Stream an artifact to ``dest`` (written to ``dest.part``, then renamed)."""
        for attempt in range(2):
            try:
                with (
                    _flows.download_to(dest, f"download of {name} from job {job_id}") as part,
                    self._http.stream("GET", _calls.artifact_path(job_id, name)) as r,
                ):
                    _raise_for_stream(r)
                    with open(part, "wb") as f:
                        for chunk in r.iter_bytes(_CHUNK):
                            f.write(chunk)
                break
            except TransportError as exc:
                if not _flows.may_resend(True, exc, attempt):
                    raise
        return Path(dest)


class AsyncClient(_Endpoints, AsyncExecutor):
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
        # artifacts on object storage may be a redirect to a presigned URL (httpx drops
        # the Authorization header when a redirect leaves the server's origin)
        self._http = httpx.AsyncClient(
            base_url=self.base_url,
            headers=_headers(api_key),
            timeout=timeout,
            transport=transport,
            follow_redirects=True,
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
                with _flows.sending(call, self.base_url) as request:
                    r = await self._http.request(**request)
                break
            except TransportError as exc:
                if not _flows.may_resend(call.repeatable, exc, attempt):
                    raise
        return call.check(r)

    async def iter_jobs(
        self, state: str | None = None, page_size: int = 100
    ) -> AsyncIterator[JobPublic]:
        """Every job of the caller, page after page."""
        offset: int | None = 0
        while offset is not None:
            page = await self.list_jobs(state, page_size, offset)
            for job in page.items:
                yield job
            offset = _flows.next_offset(offset, page)

    async def events(
        self, job_id: str, *, read_timeout: float | None = None
    ) -> AsyncIterator[JobPublic]:
        """The job's server-sent ``state`` events until it ends (as :meth:`Client.events`)."""
        stream = JobEvents()
        with _flows.transport_errors(f"event stream of job {job_id}"):
            async with self._http.stream(**_flows.events_request(job_id, read_timeout)) as r:
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
        """Follow a job (its event stream, polling if the stream breaks) until it ends.

        Raises :class:`JobFailed` / :class:`JobCancelled` unless ``raise_on_failure``
        is false, and :class:`WaitTimeout` after ``timeout`` seconds.
        """
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

    async def download(self, job_id: str, name: str, dest: str | os.PathLike[str]) -> Path:
        """Stream an artifact to ``dest`` (written to ``dest.part``, then renamed)."""
        for attempt in range(2):
            try:
                with _flows.download_to(dest, f"download of {name} from job {job_id}") as part:
                    async with self._http.stream("GET", _calls.artifact_path(job_id, name)) as r:
                        await _araise_for_stream(r)
                        with open(part, "wb") as f:
                            async for chunk in r.aiter_bytes(_CHUNK):
                                f.write(chunk)
                break
            except TransportError as exc:
                if not _flows.may_resend(True, exc, attempt):
                    raise
        return Path(dest)
