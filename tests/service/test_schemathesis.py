"""Property-based run of the OpenAPI document against the app: no input yields a
5xx, and every response conforms to the document (status code, content type,
body schema), with and without an API key.

Schemathesis generates requests for every operation from ``/openapi.json``
(valid and invalid), runs them in-process against the app (uploads validated
by the real worker code, see ``conftest.InlineTaskClient``). Bounded (a few
hundred cases in all) and derandomized so the run is reproducible.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

import pytest

schemathesis = pytest.importorskip("schemathesis")
from hypothesis import HealthCheck, settings  # noqa: E402
from schemathesis.checks import (  # noqa: E402
    content_type_conformance,
    not_a_server_error,
    response_schema_conformance,
    status_code_conformance,
)

from tests.service.conftest import Api  # noqa: E402

CHECKS = (
    not_a_server_error,
    status_code_conformance,
    content_type_conformance,
    response_schema_conformance,
)


def _api() -> Api:
    tmp = tempfile.mkdtemp(prefix="conformorph-schemathesis-")
    atexit.register(shutil.rmtree, tmp, True)
    return Api(Path(tmp))


# the upload parts' media types (openapi: encoding) are bytes, like octet-stream
schemathesis.serializer.alias(
    ["model/obj", "model/stl", "model/gltf-binary", "model/gltf+json", "image/svg+xml"],
    "application/octet-stream",
)
_OPEN = _api()  # no key exists: the server is open (to loopback clients)
_KEYED = _api()  # a key exists: requests with it, and (half of them) without
_, _KEY = _KEYED.store.create_key("schemathesis")
open_schema = schemathesis.openapi.from_asgi("/openapi.json", _OPEN.app)
keyed_schema = schemathesis.openapi.from_asgi("/openapi.json", _KEYED.app)
_RUN = settings(
    max_examples=6, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck)
)


@open_schema.parametrize()
@_RUN
def test_open_server_conforms(case: object) -> None:
    response = case.call()  # type: ignore[attr-defined]
    case.validate_response(response, checks=CHECKS)  # type: ignore[attr-defined]


@keyed_schema.parametrize()
@_RUN
def test_keyed_server_conforms_with_and_without_the_key(case: object) -> None:
    for headers in ({"Authorization": f"Bearer {_KEY}"}, {}):
        response = case.call(headers=headers)  # type: ignore[attr-defined]
        case.validate_response(response, checks=CHECKS)  # type: ignore[attr-defined]
