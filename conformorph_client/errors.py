"""Typed exceptions raised by the client, each carrying the server's message.

The server answers every error as ``{"error": {"type", "message", "field"}}``;
RFC 9457 problem details (``{"type", "title", "detail"}``) and plain-text
bodies (from a proxy, say) are understood too. The exception class follows
the HTTP status; ``type``, ``message`` and ``field`` are the server's own.
"""

from __future__ import annotations

import json
from typing import Any

import httpx


class ConformorphError(Exception):
    """Base class of every error this client raises."""


class TransportError(ConformorphError):
    """The server could not be reached or the connection broke (no HTTP answer)."""


class ApiError(ConformorphError):
    """The server answered with an error status.

    Attributes
    ----------
    status : int
        The HTTP status code.
    type : str
        The server's machine-readable error type (``"not_found"``, ``"invalid_mesh"``, ...).
    message : str
        The server's human-readable reason.
    field : str or None
        The input concerned, when the server names one.
    body : object
        The decoded body (JSON value, or the text when not JSON).
    """

    def __init__(
        self,
        status: int,
        type_: str,
        message: str,
        field: str | None = None,
        body: Any = None,
        headers: httpx.Headers | None = None,
    ) -> None:
        self.status, self.type, self.message, self.field = status, type_, message, field
        self.body = body
        self.headers = headers if headers is not None else httpx.Headers()
        where = f" [{field}]" if field else ""
        super().__init__(f"{status} {type_}{where}: {message}")


class BadRequest(ApiError):
    """400."""


class Unauthorized(ApiError):
    """401: no API key, or an unknown one."""


class Forbidden(ApiError):
    """403."""


class NotFound(ApiError):
    """404: no such mesh, job or artifact for this key."""


class Conflict(ApiError):
    """409: for example an Idempotency-Key reused for a different request."""


class PayloadTooLarge(ApiError):
    """413: an upload over the server's limit."""


class RangeNotSatisfiable(ApiError):
    """416."""


class InvalidInput(ApiError):
    """422: invalid parameters, an invalid mesh or image, or over a limit."""


class TooManyJobs(ApiError):
    """429: too many queued or running jobs for this key.

    ``retry_after`` is the server's ``Retry-After`` in seconds, if it sent one.
    """

    @property
    def retry_after(self) -> float | None:
        value = self.headers.get("retry-after")
        try:
            return float(value) if value is not None else None
        except ValueError:
            return None


class ServerError(ApiError):
    """5xx other than 503."""


class ServiceUnavailable(ServerError):
    """503: no worker or broker available."""


class JobError(ConformorphError):
    """A job ended without succeeding; ``job`` is its final public record."""

    def __init__(self, job: Any) -> None:
        self.job = job
        err = getattr(job, "error", None)
        self.type = getattr(err, "type", None) or job.state
        self.message = getattr(err, "message", None) or f"job {job.state}"
        self.field = getattr(err, "field", None)
        self.stage = getattr(err, "stage", None)
        where = f" in stage {self.stage}" if self.stage else ""
        inp = f" (input {self.field})" if self.field else ""
        super().__init__(f"job {job.id} {job.state}{where}: {self.type}: {self.message}{inp}")


class JobFailed(JobError):
    """The job ended in state ``failed``."""


class JobCancelled(JobError):
    """The job ended in state ``cancelled``."""


class WaitTimeout(ConformorphError):
    """A job did not finish within the time the caller allowed."""


_BY_STATUS: dict[int, type[ApiError]] = {
    400: BadRequest,
    401: Unauthorized,
    403: Forbidden,
    404: NotFound,
    409: Conflict,
    413: PayloadTooLarge,
    416: RangeNotSatisfiable,
    422: InvalidInput,
    429: TooManyJobs,
    503: ServiceUnavailable,
}


def error_class(status: int) -> type[ApiError]:
    """The exception class for an HTTP error status."""
    if status in _BY_STATUS:
        return _BY_STATUS[status]
    return ServerError if status >= 500 else ApiError


def error_from_response(response: httpx.Response) -> ApiError:
    """Build the typed exception for an error response (the body must have been read)."""
    status = response.status_code
    text = response.text
    body: Any = text
    type_, message, field = f"http_{status}", text.strip() or response.reason_phrase, None
    try:
        body = json.loads(text) if text else None
    except ValueError:
        pass
    if isinstance(body, dict):
        err = body.get("error")
        if isinstance(err, dict):
            type_ = str(err.get("type") or type_)
            message = str(err.get("message") or message)
            field = err.get("field") if isinstance(err.get("field"), str) else None
        elif "detail" in body or "title" in body:  # RFC 9457 problem details
            type_ = str(body.get("type") or type_)
            message = str(body.get("detail") or body.get("title") or message)
    return error_class(status)(status, type_, message, field, body, response.headers)
