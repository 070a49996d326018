"""Numerics imported before the worker's pool forks (see :func:`preload_numerics`)."""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Collection

from conformorph.worker import names

#: the package this project is installed under: "conformorph." installed (and in a
#: checkout through ``conformorph/``), "" when the folders are imported by their own names
_PREFIX = __name__.removesuffix("conformorph.worker.preload")
#: the packages whose every module a worker imports at start
PRELOADED_PACKAGES = tuple(
    p if p.startswith(_PREFIX) else _PREFIX + p
    for p in ("geometry", "pipelines", "conformorph.worker.stages")
)

#: what a worker that serves only the interactive queue (upload validations) imports
#: at start: reading and checking an uploaded mesh or shape
VALIDATION_MODULES = (
    "conformorph.worker.stages.validation",
    "conformorph.pipelines.mesh_io",
    "conformorph.pipelines.upload_validation",
)


def _modules_of(package: str) -> list[str]:
    """Every module below ``package`` (subpackages too), by its dotted name."""
    pkg = importlib.import_module(package)
    return [m.name for m in pkgutil.walk_packages(pkg.__path__, f"{package}.")]


def _import_all(modules: list[str]) -> list[str]:
    failed: list[str] = []
    for name in modules:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - a module that fails here fails loudly in its stage
            failed.append(name)
    return failed


def preload_numerics() -> list[str]:
    """Import every module of ``geometry``, ``pipelines`` and ``conformorph.worker.stages`` once, in
    the worker's main process before the pool forks, so no job pays for imports (the
    stage bodies import lazily to keep the API side light). The modules are found, not
    listed, so a module that moves or is split is still preloaded. Returns the modules
    that failed."""
    failed: list[str] = []
    found: list[str] = []
    for package in PRELOADED_PACKAGES:
        try:
            found += _modules_of(package)
        except ImportError:
            failed.append(package)
    return failed + _import_all(found)


#: queues whose tasks need no job numerics (upload validation, webhooks)
_LIGHT_QUEUES = frozenset({names.QUEUE_INTERACTIVE, names.QUEUE_WEBHOOKS})


def preload_for_queues(queues: Collection[str]) -> list[str]:
    """What a worker consuming ``queues`` imports before its pool forks.

    Parameters
    ----------
    queues : collection of str
        The Celery queue names the worker consumes (empty: not known).

    Returns
    -------
    list of str
        The modules that failed to import.

    Notes
    -----
    A worker that runs job stages (:data:`conformorph.worker.names.QUEUE_JOBS`), or whose queues
    are not known, preloads everything (:func:`preload_numerics`); one that serves only
    the interactive queue imports :data:`VALIDATION_MODULES`, so it answers (and
    ``conformorph serve`` is ready) seconds sooner, without the numerics of the morphs
    it never runs; one that serves only webhooks imports nothing more.
    """
    if not queues or names.QUEUE_JOBS in queues or not set(queues) <= _LIGHT_QUEUES:
        return preload_numerics()
    if names.QUEUE_INTERACTIVE in queues:
        return _import_all(list(VALIDATION_MODULES))
    return []  # webhooks only: an HTTP POST needs none of the numerics
