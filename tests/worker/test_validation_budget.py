"""A validation is stopped when its budget ends (issue 30), end to end: a real validation
worker kills the pool process of an upload validated past ``CONFORMORPH_VALIDATE_TIMEOUT``
(when the API has answered 503), and goes on validating the next upload."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.fixtures.make_service_small_face import small_face
from tests.worker.test_integration import Service, _env

pytestmark = pytest.mark.timeout(300)


def _slow_mesh(copies: int = 4) -> bytes:
    """``copies`` copies of a 68k-vertex face: valid after preparation, whose report takes
    several seconds even on a quiet machine (two copies took 1.2 s there: too close to a
    1 s budget for the kill to be certain)."""
    V, F = small_face(150)
    V2 = np.vstack([V + [10.0 * k, 0, 0] for k in range(copies)])
    F2 = np.vstack([F + k * len(V) for k in range(copies)])
    return (
        "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in V2)
        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F2)
    ).encode()


def test_a_validation_past_its_budget_is_killed_and_the_next_one_runs(
    tmp_path: Path, start_worker: Any, small_face_path: Path
) -> None:
    env = _env(tmp_path, CONFORMORPH_VALIDATE_TIMEOUT="0.5")
    log = tmp_path / "interactive.log"
    start_worker(env, queues="interactive", log=log)
    svc = Service(tmp_path, env)
    svc.ready()
    r = svc.client.post("/v1/meshes", files={"file": ("slow.obj", _slow_mesh())})
    assert r.status_code == 503 and r.json()["error"]["type"] == "worker_unavailable", r.text
    deadline = time.monotonic() + 60
    while "Hard time limit" not in log.read_text(errors="replace"):
        assert time.monotonic() < deadline, log.read_text(errors="replace")[-2000:]
        time.sleep(0.2)
    # the same worker validates the next upload (an API with a longer budget sends it)
    patient = Service(tmp_path, {**env, "CONFORMORPH_VALIDATE_TIMEOUT": "60"})
    t0 = time.monotonic()
    with open(small_face_path, "rb") as f:
        r = patient.client.post("/v1/meshes", files={"file": ("face.obj", f.read())})
    assert r.status_code == 201, r.text
    assert time.monotonic() - t0 < 30.0
