"""MediaPipe's own log lines stay out of the user's terminal (issue 31).

``conformorph morph A B --landmarks auto`` and ``conformorph landmarks`` print only
their own lines, with and without ``-q``: no TensorFlow Lite / absl lines (written by
C++ to file descriptor 2) and no protobuf ``GetPrototype`` deprecation warning. Run
as subprocesses so what reaches fd 2 is what a terminal would show.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from conformorph.pipelines.landmark_detection.mediapipe_detector import mediapipe_available
from tests.fixtures.fixture_faces import gpp_pair

ROOT = Path(__file__).resolve().parents[2]
#: text that only the detector's native logging or protobuf writes
NOISE = ("TensorFlow", "absl", "XNNPACK", "GetPrototype", "inference_feedback", "W0000", "I0000")


def _has_embree() -> bool:
    import trimesh

    return bool(trimesh.ray.has_embree)


needs_mediapipe = pytest.mark.skipif(
    not (mediapipe_available() and _has_embree()),
    reason="mediapipe==0.10.14 or embreex not installed (scripts/install_landmarks.sh)",
)


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for name in ("GLOG_minloglevel", "TF_CPP_MIN_LOG_LEVEL", "CONFORMORPH_NATIVE_LOG"):
        env.pop(name, None)  # as a user's shell has them: unset
    return subprocess.run(
        [sys.executable, "-m", "conformorph.cli", *args],
        capture_output=True, text=True, env=env, timeout=300, cwd=ROOT,
    )


def _own_lines_only(stderr: str) -> None:
    for noise in NOISE:
        assert noise not in stderr, stderr
    for line in stderr.splitlines():
        assert line.startswith("warning: "), stderr  # its own warnings, one a line


@needs_mediapipe
@pytest.mark.slow
@pytest.mark.parametrize("quiet", [False, True])
def test_morph_with_detected_landmarks_prints_only_its_own_lines(
    tmp_path: Path, quiet: bool
) -> None:
    a, b = gpp_pair(tmp_path)
    r = _run("morph", str(a), str(b), "--landmarks", "auto", "--frames", "3",
             "-o", str(tmp_path / "out"), *(["-q"] if quiet else []))
    assert r.returncode == 0, r.stderr
    _own_lines_only(r.stderr)
    assert r.stdout.startswith("wrote ") and len(r.stdout.splitlines()) == 1, r.stdout


@needs_mediapipe
@pytest.mark.slow
def test_landmarks_has_quiet(tmp_path: Path) -> None:
    a, b = gpp_pair(tmp_path)
    out = tmp_path / "l.json"
    loud = _run("landmarks", str(a), str(b), "-o", str(out))
    assert loud.returncode == 0, loud.stderr
    assert [ln.split(":")[0] for ln in loud.stdout.splitlines()] == [str(a), str(b), f"wrote {out}"]
    _own_lines_only(loud.stderr)
    quiet = _run("landmarks", str(a), str(b), "-o", str(out), "-q")
    assert quiet.returncode == 0, quiet.stderr
    assert quiet.stdout == f"wrote {out}\n"
    _own_lines_only(quiet.stderr)
    # the warnings a person must still see go to stderr, one per line, 1-based numbers
    said = [w for ln in loud.stdout.splitlines()[:2] for w in ln.split(" | ")[1:]]
    assert len(quiet.stderr.splitlines()) >= len(said)


def test_native_stderr_silenced_drops_fd2_only_inside() -> None:
    code = (
        "import os, sys\n"
        "from conformorph.pipelines.landmark_detection.native_log import native_stderr_silenced\n"
        "os.write(2, b'before\\n')\n"
        "with native_stderr_silenced():\n"
        "    os.write(2, b'native noise\\n')\n"
        "    with native_stderr_silenced():\n"
        "        os.write(2, b'nested noise\\n')\n"
        "    os.write(2, b'still inside\\n')\n"
        "os.write(2, b'after\\n')\n"
        "print('out', file=sys.stderr)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("CONFORMORPH_NATIVE_LOG", None)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0 and r.stderr == "before\nafter\nout\n", r.stderr
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env={**env, "CONFORMORPH_NATIVE_LOG": "1"})
    assert "native noise" in r.stderr and "nested noise" in r.stderr  # asked for: kept
