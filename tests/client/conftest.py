"""Live servers for the client tests: ``conformorph serve`` subprocesses (see tests/live_server.py)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.live_server import LiveServer, serve_fixture


@pytest.fixture(scope="session")
def live_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """An open (no API key) embedded server with one job worker."""
    yield from serve_fixture(tmp_path_factory.mktemp("live-open"))


@pytest.fixture(scope="session")
def keyed_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    """An embedded server that requires an API key (``api_key`` holds one)."""
    yield from serve_fixture(tmp_path_factory.mktemp("live-keyed"), api_key=True)
