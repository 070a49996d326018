"""The one-shot commands' malloc settings (cli.main.keep_freed_memory)."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

from conformorph.cli.main import ONE_SHOT_NUMERIC_COMMANDS, keep_freed_memory


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's")
def test_settings_apply_on_glibc_and_the_process_still_computes():
    # in a child, so that this test process keeps its own malloc behaviour
    code = (
        "import numpy as np\n"
        "from conformorph.cli.main import keep_freed_memory\n"
        "ok = keep_freed_memory()\n"
        "x = sum(float(np.ones(1 << 20).sum()) for _ in range(20))\n"
        "print(ok, x)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", str(20.0 * (1 << 20))]


def test_only_morph_is_a_one_shot_numeric_command():
    # long-running commands (serve, worker) must return memory to the system
    assert ONE_SHOT_NUMERIC_COMMANDS == frozenset({"morph"})
    assert callable(keep_freed_memory)
