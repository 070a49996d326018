"""Numerics imported before the worker's pool forks (see :func:`preload_numerics`)."""

from __future__ import annotations

import importlib
import pkgutil

#: the package this project is installed under: "conformorph." installed (and in a
#: checkout through ``conformorph/``), "" when the folders are imported by their own names
_PREFIX = __name__.removesuffix("worker.preload")
#: the packages whose every module a worker imports at start
PRELOADED_PACKAGES = tuple(
    p if p.startswith(_PREFIX) else _PREFIX + p for p in ("geometry", "pipelines", "worker.stages")
)


def _modules_of(package: str) -> list[str]:
    """Every module below ``package`` (subpackages too), by its dotted name."""
    pkg = importlib.import_module(package)
    return [m.name for m in pkgutil.walk_packages(pkg.__path__, f"{package}.")]


def preload_numerics() -> list[str]:
    """Import every module of ``geometry``, ``pipelines`` and ``worker.stages`` once, in
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
    for name in found:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - a module that fails here fails loudly in its stage
            failed.append(name)
    return failed
