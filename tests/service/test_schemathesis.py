"""Property-based run of the OpenAPI document against the app: no input yields a 5xx.

Schemathesis generates requests for every operation from ``/openapi.json``
(valid and invalid), runs them in-process against the app (uploads validated
by the real worker code, see ``conftest.InlineTaskClient``), and checks that
no response is a server error. Derandomized so the run is reproducible.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

import pytest

schemathesis = pytest.importorskip("schemathesis")
from hypothesis import HealthCheck, settings  # noqa: E402
from schemathesis.checks import not_a_server_error  # noqa: E402

from tests.service.conftest import Api  # noqa: E402

_TMP = tempfile.mkdtemp(prefix="conformorph-schemathesis-")
atexit.register(shutil.rmtree, _TMP, True)
_API = Api(Path(_TMP))
schema = schemathesis.openapi.from_asgi("/openapi.json", _API.app)


@schema.parametrize()
@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
def test_no_input_gives_a_server_error(case: object) -> None:
    response = case.call()  # type: ignore[attr-defined]
    case.validate_response(response, checks=(not_a_server_error,))  # type: ignore[attr-defined]
