"""``geometry`` loads its re-exported names on first use (geometry/_lazy_exports.py)."""

import importlib
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

from conformorph import geometry
from conformorph.geometry._lazy_exports import export_owners

ROOT = Path(__file__).resolve().parents[2]


def _run(code: str) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    return out.stdout.strip()


def test_owners_read_from_a_hand_written_init(tmp_path):
    init = tmp_path / "__init__.py"
    init.write_text(
        "from typing import TYPE_CHECKING\n"
        "from other_package import ignored\n"
        "if TYPE_CHECKING:\n"
        "    from .alpha import a, b as bee\n"
        "    from .beta import (\n"
        "        c,\n"
        "    )\n"
    )
    assert export_owners(str(init)) == {"a": "alpha", "bee": "alpha", "c": "beta"}


def test_one_name_from_two_modules_is_refused(tmp_path):
    init = tmp_path / "__init__.py"
    init.write_text("from .alpha import a\nfrom .beta import a\n")
    with pytest.raises(ValueError, match="'a' is imported from both 'alpha' and 'beta'"):
        export_owners(str(init))


def test_owners_are_exactly_the_exported_names():
    owners = export_owners(geometry.__file__)
    assert sorted(owners) == sorted(geometry.__all__)
    for name, module in owners.items():
        assert getattr(importlib.import_module(f"conformorph.geometry.{module}"), name) is getattr(
            geometry, name
        )


def test_no_exported_name_is_another_modules_submodule():
    # the package keeps an exported name over a same-named submodule only when that
    # submodule defines it (LazyPackage.__setattr__)
    owners = export_owners(geometry.__file__)
    subs = {m.name for m in pkgutil.iter_modules(geometry.__path__)}
    assert [n for n in owners if n in subs and owners[n] != n] == []


def test_import_geometry_loads_no_numerics():
    out = _run(
        "import sys, conformorph.geometry; "
        "print(sorted(m for m in sys.modules if m.startswith(('conformorph.geometry.', 'scipy', 'numpy'))))"
    )
    assert out == "['conformorph.geometry._lazy_exports']"


def test_a_submodule_import_keeps_the_same_named_function_on_the_package():
    out = _run(
        "import conformorph.geometry\n"
        "from conformorph.geometry.map_quality import map_quality\n"
        "import importlib\n"
        "mod = importlib.import_module('conformorph.geometry.disk_conformal_map')\n"
        "print(conformorph.geometry.map_quality is map_quality, "
        "conformorph.geometry.disk_conformal_map is mod.disk_conformal_map, callable(conformorph.geometry.map_quality))"
    )
    assert out == "True True True"


def test_unknown_names_raise_attribute_error_and_submodules_resolve():
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        geometry.no_such_name  # noqa: B018
    assert geometry.tolerances is importlib.import_module("conformorph.geometry.tolerances")
    assert not hasattr(geometry, "__no_such_dunder__")
    assert "map_quality" in dir(geometry) and "threads" not in geometry.__all__
