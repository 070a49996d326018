"""Python client of the conformorph REST API: sync :class:`Client` and async :class:`AsyncClient`.

Responses are the server's own pydantic models (:mod:`conformorph_client.models`);
errors are typed exceptions (:mod:`conformorph_client.errors`) carrying the
server's message.
"""

from conformorph_client.client import AsyncClient, Client
from conformorph_client.errors import (
    ApiError,
    BadRequest,
    Conflict,
    ConformorphError,
    Forbidden,
    InvalidInput,
    JobCancelled,
    JobError,
    JobFailed,
    NotFound,
    PayloadTooLarge,
    RangeNotSatisfiable,
    ServerError,
    ServiceUnavailable,
    TooManyJobs,
    TransportError,
    Unauthorized,
    WaitTimeout,
)

__all__ = [
    "ApiError",
    "AsyncClient",
    "BadRequest",
    "Client",
    "Conflict",
    "ConformorphError",
    "Forbidden",
    "InvalidInput",
    "JobCancelled",
    "JobError",
    "JobFailed",
    "NotFound",
    "PayloadTooLarge",
    "RangeNotSatisfiable",
    "ServerError",
    "ServiceUnavailable",
    "TooManyJobs",
    "TransportError",
    "Unauthorized",
    "WaitTimeout",
]
