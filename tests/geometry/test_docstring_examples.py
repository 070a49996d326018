"""The ``Examples`` sections of geometry's docstrings run and give what they show."""

import doctest
import importlib
import pkgutil

import pytest

from conformorph import geometry

MODULES = sorted(m.name for m in pkgutil.iter_modules(geometry.__path__) if not m.name.startswith("_"))


@pytest.mark.parametrize("name", MODULES)
def test_examples(name):
    module = importlib.import_module(f"conformorph.geometry.{name}")
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{result.failed} docstring example(s) of conformorph.geometry.{name} failed"
