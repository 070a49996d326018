"""A worker starts without noise a person cannot act on (issue 31): no "No hostname was
supplied" per connection to the embedded broker, and Celery's superuser warning said
once, with the reason it does not apply, instead of ten lines per worker."""

from __future__ import annotations

import logging
import warnings
from pathlib import Path

import pytest

from conformorph.cli import cmd_worker
from conformorph.worker.celery_app import create_celery_app
from conformorph.worker.config import WorkerSettings


def test_the_embedded_broker_logs_no_hostname_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    app = create_celery_app(WorkerSettings(data_dir=tmp_path))
    with caplog.at_level(logging.WARNING, logger="kombu.connection"):
        with app.connection_for_write() as conn:
            conn.info()  # what the worker's banner and every (re)connection call
            conn.as_uri()
    assert not [r for r in caplog.records if "No hostname" in r.getMessage()], caplog.text


def test_superuser_warning_is_said_once_by_us(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from celery.exceptions import SecurityWarning
    from celery.platforms import ROOT_DISCOURAGED

    monkeypatch.setattr(cmd_worker.os, "geteuid", lambda: 0)
    monkeypatch.delenv(cmd_worker.ROOT_EXPLAINED_ENV, raising=False)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        cmd_worker.explain_superuser()
        warnings.warn(SecurityWarning(ROOT_DISCOURAGED.format(uid=0, euid=0, gid=0, egid=0)), stacklevel=1)
    assert not [w for w in seen if issubclass(w.category, SecurityWarning)]
    assert capsys.readouterr().err == f"conformorph worker: {cmd_worker.ROOT_NOTE}\n"
    # started by conformorph serve, which has said it: the worker says nothing
    monkeypatch.setenv(cmd_worker.ROOT_EXPLAINED_ENV, "1")
    with warnings.catch_warnings():
        cmd_worker.explain_superuser()
    assert capsys.readouterr().err == ""


def test_not_root_changes_nothing(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(cmd_worker.os, "geteuid", lambda: 1000)
    with warnings.catch_warnings():
        before = list(warnings.filters)
        cmd_worker.explain_superuser()
        assert warnings.filters == before
    assert capsys.readouterr().err == ""
