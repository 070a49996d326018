"""``conformorph submit`` against a live embedded server (real worker, real pipeline)."""

from __future__ import annotations

import json
import os
import pty
import select
import struct
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from conformorph.cli.main import main
from conformorph_client import Client
from tests.live_server import ROOT, LiveServer, free_port, serve_fixture, small_face_pair

pytestmark = pytest.mark.timeout(240)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    yield from serve_fixture(tmp_path_factory.mktemp("submit-server"))


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    return small_face_pair(tmp_path_factory.mktemp("pair"))


def _glb_json(path: Path) -> dict[str, object]:
    data = path.read_bytes()
    assert data[:4] == b"glTF"
    (length,) = struct.unpack_from("<I", data, 12)
    assert data[16:20] == b"JSON"
    doc: dict[str, object] = json.loads(data[20 : 20 + length])
    return doc


def test_submit_downloads_animation_and_metrics(
    server: LiveServer,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b, lm = pair
    out = tmp_path / "out"
    argv = [str(a), str(b), "--landmarks", str(lm), "--frames", "7", "--server", server.url]
    rc = main(["submit", *argv, "-o", str(out)])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    doc = _glb_json(out / "animation.glb")
    targets = doc["meshes"][0]["primitives"][0]["targets"]  # type: ignore[index]
    assert len(targets) == 7
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics
    job = json.loads((out / "job.json").read_text())
    assert job["state"] == "succeeded" and job["params"]["frames"] == 7
    assert "animation.glb" in captured.out and job["id"] in captured.out
    # the same command again is the same request: the server returns the same job
    rc = main(["submit", *argv, "-o", str(tmp_path / "again"), "--quiet"])
    again = capsys.readouterr()
    assert rc == 0 and job["id"] in again.out
    assert again.err == ""  # --quiet: nothing on stderr
    assert (tmp_path / "again" / "animation.glb").read_bytes() == (
        out / "animation.glb"
    ).read_bytes()


def test_failed_job_exits_nonzero_with_the_servers_reason(
    server: LiveServer,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b, _ = pair
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"landmarks": [[0, 1, 9999], [0, 1, 2]]}))
    rc = main(
        ["submit", str(a), str(b), "--landmarks", str(bad), "--server", server.url, "-o", "o"]
    )
    err = capsys.readouterr().err
    assert rc == 1
    assert "failed" in err and "9999" in err and "out of range" in err
    assert not Path("o").exists()


def test_refused_request_exits_2_with_the_servers_reason(
    server: LiveServer,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b, lm = pair
    with Client(server.url) as c:
        before = c.list_jobs().total
    rc = main(
        [
            "submit",
            *(str(a), str(b)),
            *("--landmarks", str(lm), "--frames", "100000"),
            *("--server", server.url, "-o", str(tmp_path)),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "too_many_frames" in err and "limit" in err
    with Client(server.url) as c:
        assert c.list_jobs().total == before


def test_frame_times_reach_the_server_which_checks_them(
    server: LiveServer,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b, lm = pair
    argv = ["submit", str(a), str(b), "--landmarks", str(lm), "--server", server.url]
    rc = main([*argv, "--frame-times", "0,0.5,0.5", "--refine", "none", "-o", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "frame_times[2]" in err and "strictly increasing" in err
    with pytest.raises(SystemExit) as info:  # one or the other, as 'conformorph morph'
        main([*argv, "--frames", "3", "--frame-times", "0,1", "-o", str(tmp_path)])
    assert info.value.code == 2


def test_submit_repairs_a_holed_eared_mesh_only_when_asked(
    server: LiveServer,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from tests.live_server import holed_eared_pair

    a, bad, lm2 = holed_eared_pair(tmp_path / "in")
    argv = ["submit", str(a), str(bad), "--landmarks", str(lm2), "--server", server.url]
    # without the preparation step (the default, as 'conformorph morph', is --prepare auto)
    rc = main([*argv, "--frames", "3", "--prepare", "none", "-o", str(tmp_path / "no")])
    err = capsys.readouterr().err
    assert rc == 2 and "mesh_needs_repair" in err and "fill_holes: true" in err
    out = tmp_path / "yes"
    rc = main(
        [*argv, "--frames", "3", "--prepare", "none", "--fill-holes", "--remove-ears"]
        + ["-o", str(out)]
    )
    assert rc == 0, capsys.readouterr().err
    assert json.loads((out / "job.json").read_text())["params"]["remove_ears"] is True
    assert (out / "animation.glb").read_bytes()[:4] == b"glTF"
    # or the server's preparation step, with the tolerant landmark fit
    out = tmp_path / "prepared"
    extra = ["--prepare", "auto", "--landmark-fit", "tolerant", "--vertex-budget", "0"]
    rc = main([*argv, "--frames", "3", *extra, "-o", str(out)])
    assert rc == 0, capsys.readouterr().err
    params = json.loads((out / "job.json").read_text())["params"]
    assert params["prepare"] == "auto" and params["landmark_fit"] == "tolerant"
    assert params["vertex_budget"] == 0  # "never decimate" is sent, not dropped
    assert (out / "animation.glb").read_bytes()[:4] == b"glTF"


def test_bad_local_input_is_caught_before_contacting_the_server(
    pair: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b, _ = pair
    three = tmp_path / "three.json"
    three.write_text(json.dumps({"landmarks": [[0, 1, 2], [0, 1, 2], [0, 1, 2]]}))
    nowhere = f"http://127.0.0.1:{free_port()}"
    rc = main(["submit", str(a), str(b), "--landmarks", str(three), "--server", nowhere, "-o", "x"])
    err = capsys.readouterr().err
    assert rc == 2 and "3 lists but 2 meshes" in err and "Traceback" not in err
    rc = main(["submit", str(a), "--landmarks", str(three), "--server", nowhere, "-o", "x"])
    assert rc == 2 and "at least 2 meshes" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(["submit", str(a), str(b), "--vertex-budget", "500", "--server", nowhere, "-o", "x"])
    assert info.value.code == 2 and "at least 1000, got 500" in capsys.readouterr().err


def test_unreachable_server(
    pair: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    a, b, lm = pair
    nowhere = f"http://127.0.0.1:{free_port()}"
    rc = main(["submit", str(a), str(b), "--landmarks", str(lm), "--server", nowhere, "-o", "x"])
    err = capsys.readouterr().err
    assert rc == 1 and nowhere in err and "Traceback" not in err


def test_progress_bar_on_a_terminal_shows_the_stage(
    server: LiveServer, pair: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    a, b, lm = pair
    master, slave = pty.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "conformorph.cli", "submit", str(a), str(b), "--landmarks", str(lm)]
        + ["--frames", "9", "--server", server.url, "-o", str(tmp_path / "tty")],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=slave,
        cwd=ROOT,
        env={**os.environ, "COLUMNS": "120", "TERM": "xterm"},
    )
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], 60)
        if not ready:
            break
        try:
            data = os.read(master, 65536)
        except OSError:
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    out, _ = proc.communicate(timeout=60)
    screen = b"".join(chunks).decode(errors="replace")
    assert proc.returncode == 0, screen
    assert "morph" in screen and "succeeded" in screen and "100%" in screen
    assert any(stage in screen for stage in ("prepare", "register", "frames", "export"))
    assert b"animation.glb" in out


def test_keyed_server_needs_the_key(
    tmp_path_factory: pytest.TempPathFactory,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b, lm = pair
    for srv in serve_fixture(tmp_path_factory.mktemp("submit-keyed"), api_key=True):
        argv = ["submit", str(a), str(b), "--landmarks", str(lm), "--server", srv.url]
        assert main([*argv, "-o", str(tmp_path / "nokey")]) == 2
        assert "API key" in capsys.readouterr().err
        assert srv.api_key
        rc = main([*argv, "--api-key", srv.api_key, "--frames", "4", "-o", str(tmp_path / "k")])
        assert rc == 0, capsys.readouterr().err
        assert (tmp_path / "k" / "animation.glb").is_file()


def test_full_queue_is_waited_for_then_reported(
    tmp_path_factory: pytest.TempPathFactory,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    start_worker: Any,
) -> None:
    a, b, lm = pair
    # no job worker and one active job per key: a queued job holds the only slot
    for srv in serve_fixture(
        tmp_path_factory.mktemp("submit-busy"),
        workers=0,
        env={"CONFORMORPH_MAX_ACTIVE_JOBS": "1"},
    ):
        start_worker(srv.env, queues="interactive")  # uploads are validated by a worker
        with Client(srv.url) as c:
            c.create_conformal_map(c.upload_mesh(a).id)
        argv = ["submit", str(a), str(b), "--landmarks", str(lm), "--server", srv.url]
        rc = main([*argv, "--timeout", "4", "-o", str(tmp_path / "busy")])
        err = capsys.readouterr().err
        assert rc == 2
        assert "server busy" in err and "retrying" in err  # it waited first
        assert "too_many_jobs" in err and "limit is 1" in err  # then gave the server's reason


def test_per_frame_glbs_are_fetched(
    server: LiveServer,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b, lm = pair
    out = tmp_path / "pf"
    argv = [str(a), str(b), "--landmarks", str(lm), "--frames", "3", "--per-frame"]
    assert main(["submit", *argv, "--server", server.url, "-o", str(out), "-q"]) == 0
    capsys.readouterr()
    frames = sorted(p.name for p in (out / "frames").iterdir())
    assert len(frames) == 3 and all(f.endswith(".glb") for f in frames)
    for f in frames:
        doc = _glb_json(out / "frames" / f)
        assert "targets" not in doc["meshes"][0]["primitives"][0]  # type: ignore[index]


def test_normals_are_requested_and_delivered(
    server: LiveServer,
    pair: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b, lm = pair
    argv = [str(a), str(b), "--landmarks", str(lm), "--frames", "3", "--server", server.url, "-q"]
    assert main(["submit", *argv, "--no-normals", "-o", str(tmp_path / "plain")]) == 0
    assert main(["submit", *argv, "-o", str(tmp_path / "normals")]) == 0  # the default
    capsys.readouterr()
    plain = _glb_json(tmp_path / "plain" / "animation.glb")["meshes"][0]["primitives"][0]  # type: ignore[index]
    with_n = _glb_json(tmp_path / "normals" / "animation.glb")["meshes"][0]["primitives"][0]  # type: ignore[index]
    # the base mesh's smooth normals are always there (issue 20); NORMAL morph deltas are
    # written by default (issue 29), --no-normals leaves them out
    assert "NORMAL" in plain["attributes"] and "NORMAL" in with_n["attributes"]
    assert not any("NORMAL" in t for t in plain["targets"])
    assert all("NORMAL" in t for t in with_n["targets"])
    job = json.loads((tmp_path / "plain" / "job.json").read_text())
    assert job["params"]["normals"] is False
