"""Where stage 1 prepares big key files: threads for library calls, spawned processes
only when ``FaceMorphOptions.key_processes`` asks (the CLI, whose ``__main__`` is guarded).

Each case runs a script in a fresh interpreter, with the size threshold lowered so the
committed small faces count as big.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from conformorph.geometry.threads import available_threads
from tests.live_server import small_face_pair

pytestmark = pytest.mark.timeout(180)

_BODY = """
import json, sys
from conformorph.pipelines.face_morph import FaceMorphOptions, run_face_morph
from conformorph.pipelines.face_morph import run as run_module

run_module.PROCESS_KEYS_MIN_BYTES = 0  # the small faces count as big
a, b, lm, out, processes = sys.argv[1:6]
options = FaceMorphOptions(frames=3, write_glb=False, key_processes=processes == "1")
metrics = run_face_morph([a, b], lm, out, options)
print(json.dumps({"ok": bool(metrics)}))
"""


def _run(script: str, tmp_path: Path, processes: bool) -> subprocess.CompletedProcess[str]:
    a, b, lm = small_face_pair(tmp_path / "in")
    path = tmp_path / "user_script.py"
    path.write_text(script)
    argv = [sys.executable, str(path), str(a), str(b), str(lm), str(tmp_path / "out")]
    return subprocess.run(
        [*argv, "1" if processes else "0"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=170,
    )


def test_a_script_without_a_main_guard_runs_on_threads_by_default(tmp_path: Path) -> None:
    done = _run(textwrap.dedent(_BODY), tmp_path, processes=False)
    assert done.returncode == 0, done.stderr
    assert '"ok": true' in done.stdout


@pytest.mark.skipif(available_threads() < 2, reason="one worker: keys never go to processes")
def test_key_processes_prepare_in_spawned_processes_under_a_guard(tmp_path: Path) -> None:
    guarded = "def main():\n" + textwrap.indent(textwrap.dedent(_BODY), "    ")
    guarded += "\n\nif __name__ == '__main__':\n    main()\n"
    done = _run(guarded, tmp_path, processes=True)
    assert done.returncode == 0, done.stderr
    assert '"ok": true' in done.stdout


@pytest.mark.skipif(available_threads() < 2, reason="one worker: keys never go to processes")
def test_key_processes_without_a_guard_is_what_the_option_warns_of(tmp_path: Path) -> None:
    """The reason the option is off by default: the spawned children re-run the script."""
    done = _run(textwrap.dedent(_BODY), tmp_path, processes=True)
    assert done.returncode != 0
    assert "BrokenProcessPool" in done.stderr or "bootstrapping" in done.stderr
