"""A real ``conformorph serve`` (API plus its Celery worker processes) for client tests.

The server runs as a subprocess on a free loopback port with its own data
folder. With ``api_key=True`` a key is created first (``conformorph keys
create``), so the server requires it. :meth:`LiveServer.stop` SIGKILLs, by PID,
the server and then every process it started (test data needs no graceful
shutdown, and a killed server restarts no worker).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def server_env(data_dir: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
    env.update(
        PYTHONPATH=str(ROOT),
        CONFORMORPH_DATA_DIR=str(data_dir),
        OPENBLAS_NUM_THREADS="1",
        OMP_NUM_THREADS="1",
    )
    return env


def _descendants(pid: int) -> list[int]:
    """PIDs of every live descendant of ``pid`` (read from /proc)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        children.setdefault(ppid, []).append(int(entry.name))
    out: list[int] = []
    todo = [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.append(c)
            todo.append(c)
    return out


class LiveServer:
    """``conformorph serve`` on a free port; ``url`` and ``api_key`` (None when open)."""

    def __init__(
        self,
        data_dir: Path,
        *,
        api_key: bool = False,
        workers: int = 1,
        log: Path | None = None,
        env: dict[str, str] | None = None,
    ) -> None:
        self.data_dir = data_dir
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.env = {**server_env(data_dir), **(env or {})}
        self.api_key: str | None = None
        self.log_path = log or data_dir / "serve.log"
        data_dir.mkdir(parents=True, exist_ok=True)
        if api_key:
            self.api_key = self.create_key("tests")
        self._log = open(self.log_path, "ab")  # noqa: SIM115
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "conformorph.cli",
                "serve",
                "--port",
                str(self.port),
                "--data-dir",
                str(data_dir),
                "--workers",
                str(workers),
            ],
            env=self.env,
            cwd=ROOT,
            stdout=self._log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self._started: set[int] = set()

    def create_key(self, name: str) -> str:
        out = subprocess.run(
            [sys.executable, "-m", "conformorph.cli", "keys", "create", name, "--data-dir", str(self.data_dir)],
            env=self.env,
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        )
        return out.stdout.split()[-1]

    def wait_ready(self, timeout: float = 180.0, *, probe: str = "/readyz") -> None:
        """Wait until ``probe`` answers 200: ``/readyz`` (a worker serves the validation
        queue), or ``/healthz`` for a server started without workers, which is not
        ready until the test starts one."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                if httpx.get(f"{self.url}{probe}", timeout=2).status_code == 200:
                    self._started.update(_descendants(self.proc.pid))
                    return
            except httpx.TransportError:
                pass
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(
                    f"conformorph serve did not become ready; log:\n{self.log_text()[-3000:]}"
                )
            time.sleep(0.2)

    def log_text(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except OSError:
            return ""

    def stop(self) -> None:
        """Kill the server, then its worker processes (by PID; test data needs no
        graceful shutdown). The server goes first so that it restarts no worker."""
        pids = self._started | set(_descendants(self.proc.pid))
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        for _ in range(2):  # pool children forked meanwhile are caught by the second pass
            for pid in list(pids):
                pids |= set(_descendants(pid))
            self._kill_ours(pids)
        self._log.close()

    @staticmethod
    def _kill_ours(pids: set[int]) -> None:
        for pid in pids:
            try:
                cmd = Path(f"/proc/{pid}/cmdline").read_bytes()
            except OSError:
                continue  # already gone
            if b"cli" in cmd or b"celery" in cmd:  # ours, not a recycled PID
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass


SMALL_FACE = ROOT / "tests" / "fixtures" / "service_small_face.obj"
#: vertices of the small face used as landmarks (spread over the surface)
SMALL_FACE_LANDMARKS = [0, 40, 80, 120, 160, 200]


def small_face_pair(folder: Path) -> tuple[Path, Path, Path]:
    """Two key meshes for a quick morph and their landmark file, written to ``folder``.

    The first is the committed 331-vertex face; the second the same mesh
    stretched (x by 1.05, z by 1.2 plus a shear): same connectivity, so the
    same vertex ids are landmarks on both.
    """
    folder.mkdir(parents=True, exist_ok=True)
    a = folder / "face_a.obj"
    b = folder / "face_b.obj"
    a.write_bytes(SMALL_FACE.read_bytes())
    out = []
    for line in SMALL_FACE.read_text().splitlines():
        if line.startswith("v "):
            x, y, z = (float(t) for t in line.split()[1:4])
            out.append(f"v {x * 1.05:.6f} {y:.6f} {z * 1.2 + 0.02 * x:.6f}")
        else:
            out.append(line)
    b.write_text("\n".join(out) + "\n")
    lm = folder / "landmarks.json"
    lm.write_text(json.dumps({"landmarks": [SMALL_FACE_LANDMARKS, SMALL_FACE_LANDMARKS]}))
    return a, b, lm


def holed_eared_pair(folder: Path) -> tuple[Path, Path, Path]:
    """The committed face and a copy with a hole and an ear (stored by the server with
    ``repairs_needed``), with a landmark file valid for both; written to ``folder``."""
    from conformorph.pipelines.mesh_io import read_mesh, write_obj
    from tests.fixtures.make_service_small_face import with_hole_and_ear

    a, _, lm = small_face_pair(folder)
    V, F, _ = with_hole_and_ear(*read_mesh(a))
    b = folder / "holed_eared.obj"
    write_obj(b, V, F)
    ids = [i for i in SMALL_FACE_LANDMARKS if i != 0]  # vertex 0 is cut out of b
    lm.write_text(json.dumps({"landmarks": [ids, [i - 1 for i in ids]]}))
    return a, b, lm


def serve_fixture(tmp: Path, **kw: object) -> Iterator[LiveServer]:
    """Body of a pytest fixture: a ready server, stopped afterwards."""
    srv = LiveServer(tmp, **kw)  # type: ignore[arg-type]
    try:
        srv.wait_ready(probe="/readyz" if kw.get("workers", 1) else "/healthz")
        yield srv
    finally:
        srv.stop()
