"""The worker preloads every numerics module, found on disk, not listed by hand."""

from __future__ import annotations

from pathlib import Path

from worker.preload import PRELOADED_PACKAGES, _modules_of, preload_numerics

ROOT = Path(__file__).resolve().parents[2]


def _modules_on_disk(package: str) -> set[str]:
    folder = ROOT.joinpath(*package.split("."))
    out = set()
    for path in folder.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        out.add(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return out - {package}


def test_every_module_of_the_preloaded_packages_is_found() -> None:
    for package in PRELOADED_PACKAGES:
        assert set(_modules_of(package)) == _modules_on_disk(package), package


def test_preload_imports_everything_without_failures() -> None:
    assert preload_numerics() == []
