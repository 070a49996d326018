"""The ``geometry`` package re-exports the public API of every geometry module."""

import importlib
import inspect
import pkgutil
from collections import defaultdict
from types import ModuleType

from conformorph import geometry


def _public_modules() -> list[ModuleType]:
    return [
        importlib.import_module(f"conformorph.geometry.{m.name}")
        for m in pkgutil.iter_modules(geometry.__path__)
        if not m.name.startswith("_")
    ]


def _defined_api(mod: ModuleType) -> list[str]:
    """Public functions and classes a module defines itself (not ones it imports)."""
    return [
        name
        for name, obj in vars(mod).items()
        if not name.startswith("_")
        and (inspect.isfunction(obj) or inspect.isclass(obj))
        and obj.__module__ == mod.__name__
    ]


def _owners() -> dict[str, list[str]]:
    owners: dict[str, list[str]] = defaultdict(list)
    for mod in _public_modules():
        for name in _defined_api(mod):
            owners[name].append(mod.__name__)
    return owners


def test_every_name_in_all_resolves_and_is_unique():
    assert len(geometry.__all__) == len(set(geometry.__all__))
    for name in geometry.__all__:
        obj = getattr(geometry, name)
        assert inspect.isfunction(obj) or inspect.isclass(obj), name
        assert obj.__module__.startswith("conformorph.geometry."), name


def test_every_module_function_and_class_is_exported_from_its_module():
    owners = _owners()
    ambiguous = {name for name, mods in owners.items() if len(mods) > 1}
    missing = []
    for name, mods in owners.items():
        if name in ambiguous:
            continue
        if name not in geometry.__all__:
            missing.append(f"{mods[0]}.{name}")
            continue
        # the package name is the module's own object, not a same-named other one
        assert getattr(geometry, name) is getattr(importlib.import_module(mods[0]), name)
    assert missing == [], (
        "re-export these from geometry/__init__.py (import and __all__), "
        "or give them a leading underscore if they are not public"
    )
    # a name two modules define is left out rather than picked arbitrarily
    assert not ambiguous & set(geometry.__all__)
    # and __all__ holds nothing beyond the modules' own API
    assert set(geometry.__all__) <= set(owners)


def test_each_module_main_function_is_exported():
    # a module named after its main function (disk_conformal_map, strain_morph, ...)
    # exports it; locate_points is defined by two modules and is the one exception
    owners = _owners()
    mains = [
        mod.__name__.rpartition(".")[2]
        for mod in _public_modules()
        if callable(vars(mod).get(mod.__name__.rpartition(".")[2]))
    ]
    assert len(mains) > 20  # the check below is not vacuous
    for name in mains:
        if len(owners[name]) > 1:
            continue
        assert name in geometry.__all__, name
        assert callable(getattr(geometry, name)), name
