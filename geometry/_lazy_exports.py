"""The lazy re-exports of the ``geometry`` package (:pep:`562`).

``geometry/__init__.py`` lists its re-exports as ``from .module import name`` statements
under ``if TYPE_CHECKING:`` (read by type checkers, not run); :func:`export_owners` reads
those statements from the package's source, and :class:`LazyPackage` imports a name's
module the first time the name is used.
"""

from __future__ import annotations

import ast
import importlib
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any


@cache
def export_owners(init_path: str) -> dict[str, str]:
    """Exported name → the submodule defining it, from a package ``__init__``'s imports.

    Parameters
    ----------
    init_path : str
        The package's ``__init__.py``.

    Returns
    -------
    dict
        Every ``name`` of a relative ``from .module import name`` statement of the file
        (at any depth, so those under ``if TYPE_CHECKING:`` count) → ``module``.

    Raises
    ------
    ValueError
        When two statements export the same name from different modules.
    """
    tree = ast.parse(Path(init_path).read_text(encoding="utf-8"), filename=init_path)
    owners: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
            for alias in node.names:
                name = alias.asname or alias.name
                if owners.get(name, node.module) != node.module:
                    raise ValueError(
                        f"{init_path}: {name!r} is imported from both "
                        f"{owners[name]!r} and {node.module!r}"
                    )
                owners[name] = node.module
    return owners


class LazyPackage(ModuleType):
    """A package module whose re-exported names import their module on first use.

    The import system binds every imported submodule on its package
    (``conformorph.geometry.map_quality = <module>``); where a submodule shares its name with a
    name the package re-exports (the function ``map_quality``), the package keeps the
    re-exported object, as an eager ``from .map_quality import map_quality`` would.
    Names that are neither re-exported nor set are looked up as submodules
    (``conformorph.geometry.tolerances``).
    """

    def _owners(self) -> dict[str, str]:
        return export_owners(str(self.__file__))

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(f"module {self.__name__!r} has no attribute {name!r}")
        owner = self._owners().get(name)
        if owner is None:
            try:
                return importlib.import_module(f"{self.__name__}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{self.__name__}.{name}":
                    raise
                raise AttributeError(
                    f"module {self.__name__!r} has no attribute {name!r}"
                ) from None
        value = getattr(importlib.import_module(f"{self.__name__}.{owner}"), name)
        ModuleType.__setattr__(self, name, value)
        return value

    def __setattr__(self, name: str, value: Any) -> None:
        if (
            isinstance(value, ModuleType)
            and value.__name__ == f"{self.__name__}.{name}"
            and self._owners().get(name) == name
        ):
            value = getattr(value, name)
        ModuleType.__setattr__(self, name, value)

    def __dir__(self) -> list[str]:
        return sorted(set(super().__dir__()) | set(self._owners()))
