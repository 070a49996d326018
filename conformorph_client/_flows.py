"""The flows both clients run around a :class:`~conformorph_client._calls.Call`:
sending it (uploads opened and closed, transport failures typed, one resend after a
dropped keep-alive connection), reading a job's event stream, paging, downloading
to a file, and following a job to its end. The clients keep only the I/O itself
(``await`` or not).
"""

from __future__ import annotations

import json
import mimetypes
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx

from conformorph_client._calls import Call, UploadSource, events_path
from conformorph_client.errors import JobCancelled, JobFailed, TransportError, WaitTimeout
from conformorph_client.models import TERMINAL_STATES, JobList, JobPublic

# --------------------------------------------------------------------------- uploads


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
