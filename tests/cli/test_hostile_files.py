"""Every file of the malformed corpus through the CLI: one line on stderr, exit code 2 (issue 15).

Most files run in-process (``conformorph.cli.main.main``); a sample of each format runs as
``python -m conformorph.cli`` to check the real process's exit code and stderr.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from conformorph.cli.main import main
from tests.fixtures.malformed_corpus import write_corpus

SHAPES = Path(__file__).resolve().parents[1] / "fixtures" / "shapes"
ROOT = Path(__file__).resolve().parents[2]


def _args(path: Path, out: Path) -> list[str]:
    if path.suffix in (".svg", ".json"):
        return [
            "morph2d", str(path), str(SHAPES / "bar_bent.json"),
            "--anchors", str(SHAPES / "bar_anchors.json"), "-o", str(out), "--quiet",
        ]  # fmt: skip
    return ["map", str(path), "-o", str(out / "map.npz"), "--quiet"]


@pytest.fixture(scope="module")
def corpus_files(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return [p for _, p in write_corpus(tmp_path_factory.mktemp("corpus"))]


def test_every_malformed_file_is_one_line_and_exit_2(
    corpus_files: list[Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    failures = []
    for path in corpus_files:
        command = "morph2d" if path.suffix in (".svg", ".json") else "map"
        rc = main(_args(path, tmp_path))
        err = capsys.readouterr().err.strip()
        if rc != 2 or "\n" in err or not err.startswith(f"conformorph {command}: error: "):
            failures.append(f"{path.name}: exit {rc}: {err[:300]!r}")
    assert not failures, "\n".join(failures)


def test_a_sample_as_real_processes(corpus_files: list[Path], tmp_path: Path) -> None:
    seen: set[str] = set()
    sample = []
    for path in corpus_files:  # the first file of each format, and every external reference
        if path.suffix not in seen or "_ref" in path.name:
            seen.add(path.suffix)
            sample.append(path)
    for path in sample[:16]:
        run = subprocess.run(
            [sys.executable, "-m", "conformorph.cli", *_args(path, tmp_path)],
            capture_output=True, text=True, cwd=ROOT, timeout=120, check=False,
        )  # fmt: skip
        lines = run.stderr.strip().splitlines()
        assert run.returncode == 2 and len(lines) == 1, (path.name, run.stderr)
        assert "Traceback" not in run.stderr
