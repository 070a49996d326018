"""The distributions as users install them (slow: builds wheels, makes fresh venvs).

* ``conformorph-client`` alone in a fresh venv (httpx and pydantic, no numerics, no
  server) does a submit -> wait -> download round trip against a live server.
* ``pip install .`` of the server alone in a fresh venv (no client wheel offered, as a
  user installing from a clone or ``git+URL`` has none) works: it puts ``conformorph``
  and the client package it carries, ``conformorph_client``, in site-packages (its
  RECORD), carries the built viewer, ``conformorph serve`` from it serves ``/`` and
  ``conformorph submit`` finds its client.

Wheels are built with pip (build isolation; pip's cache makes the venvs quick after
the first run). The viewer build needs npm: without it and without a build in
``service/static`` the test skips, saying so.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
import venv
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.live_server import ROOT, LiveServer, free_port, serve_fixture

pytestmark = [pytest.mark.slow, pytest.mark.timeout(900)]

SMALL_FACE = ROOT / "tests" / "fixtures" / "service_small_face.obj"
HEAVY = ("numpy", "scipy", "celery", "fastapi", "trimesh", "uvicorn", "sqlalchemy")


def _clean_env() -> dict[str, str]:
    """The environment without this checkout on the path (a user's shell)."""
    return {
        k: v for k, v in os.environ.items() if k != "PYTHONPATH" and not k.startswith("CONFORMORPH_")
    }


def _pip(python: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(python), "-m", "pip", "--disable-pip-version-check", *args],
        capture_output=True,
        text=True,
        env=_clean_env(),
        cwd=python.parents[2],
        check=False,
    )


def _venv(folder: Path) -> Path:
    venv.EnvBuilder(with_pip=True, clear=True).create(folder)
    return folder / "bin" / "python"


@pytest.fixture(scope="module")
def wheels(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    if not (ROOT / "service" / "static" / "index.html").is_file() and shutil.which("npm") is None:
        pytest.skip("the viewer is not built and npm is missing: a server wheel cannot be built")
    dist = tmp_path_factory.mktemp("dist")
    # pip builds in the tree: leave no build/ folders behind that were not there
    fresh = [d for d in (ROOT / "build", ROOT / "conformorph_client" / "build") if not d.exists()]
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(dist),
         str(ROOT), str(ROOT / "conformorph_client")],
        capture_output=True, text=True, env=_clean_env(), check=False,
    )  # fmt: skip
    for d in fresh:
        shutil.rmtree(d, ignore_errors=True)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    print(f"built both wheels in {time.perf_counter() - t0:.1f} s")  # noqa: T201
    found = {w.name.split("-")[0]: w for w in dist.glob("*.whl")}
    assert set(found) == {"conformorph", "conformorph_client"}, found
    return found


def _site_packages(python: Path) -> Path:
    return next((python.parents[1] / "lib").glob("python3*/site-packages"))


def _timed_install(python: Path, *args: str) -> float:
    t0 = time.perf_counter()
    out = _pip(python, "install", "-q", *args)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    return time.perf_counter() - t0


def _size_mb(folder: Path) -> float:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()) / 1e6


@pytest.fixture(scope="module")
def client_venv(wheels: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    python = _venv(tmp_path_factory.mktemp("client-venv"))
    seconds = _timed_install(python, str(wheels["conformorph_client"]))
    print(f"client venv: installed in {seconds:.1f} s, {_size_mb(python.parents[1]):.0f} MB")  # noqa: T201
    return python


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    yield from serve_fixture(tmp_path_factory.mktemp("packaging-live"))


def test_client_venv_has_no_server_packages(client_venv: Path) -> None:
    out = _pip(client_venv, "list", "--format=freeze")
    names = {line.split("==")[0].lower().replace("_", "-") for line in out.stdout.splitlines()}
    assert "conformorph-client" in names and {"httpx", "pydantic"} <= names
    assert not names & set(HEAVY), names & set(HEAVY)
    assert "conformorph" not in names


ROUND_TRIP = """
import sys, zipfile
from conformorph_client import Client
url, mesh, dest = sys.argv[1:4]
with Client(url) as c:
    m = c.upload_mesh(mesh)
    job = c.create_conformal_map(m.id)
    done = c.wait(job.id, timeout=240)
    assert done.state == "succeeded", done
    path = c.download(job.id, "disk_map.npz", dest)
    assert zipfile.is_zipfile(path), path
    print("round trip", done.state, m.vertices, path.stat().st_size)
print(sorted(k for k in sys.modules if k.split(".")[0] in {HEAVY!r}))
""".replace("{HEAVY!r}", repr(set(HEAVY)))


def test_client_alone_round_trip(client_venv: Path, live: LiveServer, tmp_path: Path) -> None:
    out = subprocess.run(
        [str(client_venv), "-I", "-c", ROUND_TRIP, live.url, str(SMALL_FACE),
         str(tmp_path / "disk_map.npz")],
        capture_output=True, text=True, env=_clean_env(), cwd=tmp_path, timeout=300, check=False,
    )  # fmt: skip
    assert out.returncode == 0, out.stdout + out.stderr
    lines = out.stdout.strip().splitlines()
    assert lines[0].startswith("round trip succeeded") and lines[-1] == "[]", out.stdout
    assert (tmp_path / "disk_map.npz").stat().st_size > 0


@pytest.fixture(scope="module")
def server_venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``pip install .`` in a fresh venv: the server alone, from the checkout (issue 31)."""
    if not (ROOT / "service" / "static" / "index.html").is_file() and shutil.which("npm") is None:
        pytest.skip("the viewer is not built and npm is missing: the server cannot be built")
    python = _venv(tmp_path_factory.mktemp("server-venv"))
    fresh = [d for d in (ROOT / "build",) if not d.exists()]
    try:
        seconds = _timed_install(python, str(ROOT))
    finally:
        for d in fresh:
            shutil.rmtree(d, ignore_errors=True)
    print(f"server venv: pip install . in {seconds:.1f} s, {_size_mb(python.parents[1]):.0f} MB")  # noqa: T201
    return python


def test_server_record_has_one_top_level_package(server_venv: Path) -> None:
    site = _site_packages(server_venv)
    record = next(site.glob("conformorph-*.dist-info")) / "RECORD"
    tops = {
        line.split(",")[0].split("/")[0]
        for line in record.read_text().splitlines()
        if line and not line.startswith("..")  # the console script, in bin/
    }
    assert tops == {"conformorph", "conformorph_client", record.parent.name}, tops
    for generic in ("geometry", "pipelines", "service", "worker", "cli"):
        assert not (site / generic).exists(), generic
    assert (site / "conformorph" / "service" / "static" / "index.html").is_file()
    # the client package the server carries (also its own distribution, not required)
    assert (site / "conformorph_client" / "client.py").is_file()
    assert (site / "conformorph_client" / "py.typed").is_file()
    names = _pip(server_venv, "list", "--format=freeze").stdout.lower()
    assert "conformorph-client" not in names, names


def test_installed_server_submits_with_the_client_it_carries(
    server_venv: Path, live: LiveServer, tmp_path: Path
) -> None:
    """``conformorph submit`` from the server-only venv: a live round trip with the client
    package the server carries (the small face against itself, 3 landmarks)."""
    lm = tmp_path / "lm.json"
    lm.write_text('{"landmarks": [[0, 40, 80], [0, 40, 80]]}')
    out = subprocess.run(
        [str(server_venv.parent / "conformorph"), "submit", str(SMALL_FACE), str(SMALL_FACE),
         "--landmarks", str(lm), "--frames", "3", "--server", live.url, "-q",
         "-o", str(tmp_path / "out")],
        capture_output=True, text=True, env=_clean_env(), cwd=tmp_path, timeout=300, check=False,
    )  # fmt: skip
    assert out.returncode == 0, out.stdout + out.stderr
    assert (tmp_path / "out" / "animation.glb").stat().st_size > 0


def test_installed_server_serves_the_viewer(server_venv: Path, tmp_path: Path) -> None:
    port = free_port()
    log = tmp_path / "serve.log"
    with log.open("wb") as fh:
        proc = subprocess.Popen(
            [str(server_venv.parent / "conformorph"), "serve", "--port", str(port),
             "--workers", "0", "--data-dir", str(tmp_path / "data")],
            stdout=fh, stderr=subprocess.STDOUT, env=_clean_env(), cwd=tmp_path,
        )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                page = httpx.get(f"http://127.0.0.1:{port}/", timeout=2)
                break
            except httpx.TransportError:
                assert proc.poll() is None and time.monotonic() < deadline, log.read_text()
                time.sleep(0.3)
        assert page.status_code == 200, page.text
        assert page.headers["content-type"].startswith("text/html")
        js = httpx.get(f"http://127.0.0.1:{port}/viewer/viewer.js", timeout=10)
        assert js.status_code == 200 and len(js.content) > 100_000
        assert "not built" not in log.read_text()
    finally:
        proc.kill()
        proc.wait()
