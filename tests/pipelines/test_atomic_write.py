"""conformorph.pipelines.atomic_write: outputs renamed into place, created 0644 under umask 022."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.atomic_write import atomic_path, atomic_write_bytes, atomic_write_text
from conformorph.pipelines.export_gltf import write_frame_glb


@pytest.fixture
def umask_022() -> Iterator[None]:
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


def _mode(p: Path) -> int:
    return stat.S_IMODE(p.stat().st_mode)


def test_text_bytes_and_glb_outputs_are_0644_under_umask_022(
    umask_022: None, tmp_path: Path
) -> None:
    atomic_write_text(tmp_path / "a" / "x.json", "{}\n")
    atomic_write_bytes(tmp_path / "y.bin", b"\x00\x01")
    V = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    write_frame_glb(tmp_path / "f.glb", V, np.array([[0, 1, 2]]))
    assert (tmp_path / "a" / "x.json").read_text() == "{}\n"
    assert (tmp_path / "y.bin").read_bytes() == b"\x00\x01"
    for name in ("a/x.json", "y.bin", "f.glb"):
        assert _mode(tmp_path / name) == 0o644, name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "f.glb", "y.bin"]  # no temporaries


def test_mode_follows_a_stricter_umask(tmp_path: Path) -> None:
    old = os.umask(0o077)
    try:
        atomic_write_text(tmp_path / "x.txt", "x")
    finally:
        os.umask(old)
    assert _mode(tmp_path / "x.txt") == 0o600


def test_failure_leaves_the_old_file_and_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "x.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["x.txt"]
