"""The worker preloads every numerics module, found on disk, not listed by hand."""

from __future__ import annotations

from pathlib import Path

from conformorph.worker.preload import PRELOADED_PACKAGES, _modules_of, preload_numerics

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


def _imported_after(code: str) -> set[str]:
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code + "\nimport sys; print(' '.join(sys.modules))"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return set(out.stdout.split())


def test_a_validation_only_worker_preloads_the_validation_modules_only() -> None:
    from conformorph.worker import names
    from conformorph.worker.preload import VALIDATION_MODULES

    mods = _imported_after(
        "from conformorph.worker.preload import preload_for_queues\n"
        f"assert preload_for_queues({{{names.QUEUE_INTERACTIVE!r}}}) == []"
    )
    assert set(VALIDATION_MODULES) <= mods
    assert "conformorph.pipelines.face_morph.registration" not in mods
    assert "conformorph.pipelines.morph2d.run" not in mods


def test_a_jobs_worker_or_unknown_queues_preload_everything() -> None:
    from conformorph.worker import names

    for queues in (f"{{{names.QUEUE_JOBS!r}, {names.QUEUE_INTERACTIVE!r}}}", "set()"):
        mods = _imported_after(
            f"from conformorph.worker.preload import preload_for_queues\nassert preload_for_queues({queues}) == []"
        )
        assert {"conformorph.pipelines.face_morph.registration", "conformorph.pipelines.morph2d.run"} <= mods, queues
