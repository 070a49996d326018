"""Keep MediaPipe's native logging out of the user's terminal.

MediaPipe 0.10.14 runs TensorFlow Lite under absl/glog. Loading the models and the
first inferences write lines such as ``INFO: Created TensorFlow Lite XNNPACK delegate
for CPU``, ``WARNING: All log messages before absl::InitializeLog() ...`` and
``W0000 ... inference_feedback_manager.cc ...`` from C++ straight to file descriptor
2, where no Python logging setting reaches them, and its Python side calls protobuf's
deprecated ``SymbolDatabase.GetPrototype()``, which warns on every graph built.

Three measures, each at its source:

* :func:`quiet_native_logging_env` sets the log-level variables glog and TensorFlow
  read at start-up (``GLOG_minloglevel``, ``TF_CPP_MIN_LOG_LEVEL``), unless the user
  set them, before ``mediapipe`` is imported;
* :func:`native_stderr_silenced` points file descriptor 2 at ``/dev/null`` while the
  models load and run (absl writes its pre-initialisation lines regardless of those
  variables). Anything written to fd 2 in that window by any thread is dropped, so the
  window covers only the MediaPipe calls; ``CONFORMORPH_NATIVE_LOG=1`` turns it off
  for debugging a detector problem;
* :func:`filter_protobuf_deprecation` ignores exactly that one protobuf
  ``UserWarning`` (matched by message and module), nothing else.
"""

from __future__ import annotations

import os
import sys
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

#: set to "1" to see MediaPipe's native log lines (no redirection of fd 2)
NATIVE_LOG_ENV = "CONFORMORPH_NATIVE_LOG"
#: the start-up log levels (2: errors only) glog and TensorFlow Lite read
_LEVEL_ENV = {"GLOG_minloglevel": "2", "TF_CPP_MIN_LOG_LEVEL": "2"}
_LOCK = threading.RLock()
_DEPTH = [0]
_SAVED: list[int] = []


def native_log_wanted() -> bool:
    """True when ``CONFORMORPH_NATIVE_LOG=1`` asks for MediaPipe's own log lines."""
    return os.environ.get(NATIVE_LOG_ENV, "") == "1"


def quiet_native_logging_env() -> None:
    """Set glog's and TensorFlow's start-up log levels to errors only (unless set already)."""
    if native_log_wanted():
        return
    for name, value in _LEVEL_ENV.items():
        os.environ.setdefault(name, value)


def filter_protobuf_deprecation() -> None:
    """Ignore protobuf's ``SymbolDatabase.GetPrototype() is deprecated`` warning (only that one)."""
    warnings.filterwarnings(
        "ignore",
        message=r"SymbolDatabase\.GetPrototype\(\) is deprecated",
        category=UserWarning,
        module=r"google\.protobuf\.symbol_database",
    )


@contextmanager
def native_stderr_silenced() -> Iterator[None]:
    """Point file descriptor 2 at ``/dev/null`` for the block (re-entrant, thread-safe).

    Python's ``sys.stderr`` is flushed before and after, so nothing written before the
    block is lost; a nested or concurrent use keeps the redirection until the last one
    leaves. Does nothing when ``CONFORMORPH_NATIVE_LOG=1`` or fd 2 is not open.
    """
    if native_log_wanted():
        yield
        return
    with _LOCK:
        if _DEPTH[0] == 0:
            try:
                sys.stderr.flush()
                saved = os.dup(2)
            except (OSError, ValueError, AttributeError):
                saved = -1
            if saved >= 0:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, 2)
                os.close(devnull)
            _SAVED.append(saved)
        _DEPTH[0] += 1
    try:
        yield
    finally:
        with _LOCK:
            _DEPTH[0] -= 1
            if _DEPTH[0] == 0:
                saved = _SAVED.pop()
                if saved >= 0:
                    os.dup2(saved, 2)
                    os.close(saved)
